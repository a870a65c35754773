// What fit_link writes (docs/formats.md, "fit_link"): the channel file of a fitted link (the
// settings LossyChannel, simulate, montecarlo and analyze read, the fit's intervals as comments),
// the readable summary with a text histogram of the burst lengths, and the JSON, one writer for
// the tool and the Python module.
#pragma once

#include <string>
#include <vector>

#include "networked_estimation/link/link_fit.hpp"

namespace networked_estimation
{

/// The channel file: fit.channel as YAML (numbers that read back exactly), the fit as comments.
std::string fittedChannelYaml(const LinkFit& fit);

/// The summary of one link.
std::string linkFitText(const LinkFit& fit);

/// fit_link --json: {"links": [one object per fit]}; `series` adds each link's slots (arrived as a
/// string of 0 and 1, delays with null for a lost message).
std::string linkFitsJson(const std::vector<LinkFit>& fits, bool series);

/// The burst-length bins of the histogram: 1, 2, 3, 4, 5-8, 9-16, ... (first and last length).
std::vector<std::pair<std::size_t, std::size_t>> burstBins(std::size_t longest);

}  // namespace networked_estimation
