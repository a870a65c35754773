// Private: the model files compiled into the core (cmake/embedded_models.cmake generates the list
// from config/models at configure time).
#pragma once

#include <vector>

namespace networked_estimation
{
namespace mc
{

/// One config/models file as it was when the core was built.
struct EmbeddedModel
{
  const char* name;  ///< the file's stem, e.g. "zhou_example"
  const char* path;  ///< "config/models/<name>.yaml" (for messages)
  const char* text;  ///< the file's text
};

/// Every embedded model file, in the order of NE_EMBEDDED_MODELS.
const std::vector<EmbeddedModel>& embeddedModels();

}  // namespace mc
}  // namespace networked_estimation
