// ROS-free CSV input/output of the command-line tools (docs/formats.md, "Replay input",
// "Replay output", "Truth"): what `simulate` writes and `replay` reads and writes.
//
//   replay input:   k,gamma,y1,...,ym[,u1,...,up][,nu][,r1_1,r1_2,...]   (r: per-step R blocks)
//   replay output:  k,gamma,x1,...,xn,P11,P12,...,Pnn,trace
//   truth:          k,x1,...,xn,nu          (nu = 1 when u_k reached the actuator)
//
// Every reading error is an InputError whose message is
//   <path>:<line>: <column name>: <problem> (expected ..., found '...')
// with 1-based line numbers counting the header.
#pragma once

#include <Eigen/Dense>
#include <fstream>
#include <iosfwd>
#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"

namespace networked_estimation
{

// ---------------------------------------------------------------------------------------------
// Replay input

/// One sample of a replay input file.
struct ReplayRow
{
  long k = 0;
  bool gamma = true;
  /// Stacked y_k (size m). NaN where a sensor's cells were empty (per-sensor loss) and, on gamma = 0
  /// rows, where a cell was empty or `nan`. Finite cells of gamma = 0 rows are kept (kf uses them).
  Eigen::VectorXd y;
  /// Commanded u_k (size p; empty when the file has no u columns).
  Eigen::VectorXd u;
  /// nu_k (0 or 1); -1 when the file has no nu column.
  int nu = -1;
  /// Per sensor, whether it was scheduled to transmit (a sensor whose cells are all '-' was not:
  /// not a loss). Empty when every sensor was scheduled.
  std::vector<bool> scheduled;
  /// R_k of this step (m x m: the model's R with the blocks the row's r cells give); empty when
  /// the row gives none (the model's R).
  Eigen::MatrixXd R;
  /// Line of the file this row came from (1-based, the header is line 1).
  long line = 0;
};

struct ReplayInput
{
  std::string path;  ///< the source named in messages
  std::vector<ReplayRow> rows;
  bool has_u = false;
  bool has_nu = false;
  bool has_R = false;  ///< the file has the r columns
};

/// Reads and validates a replay input file against the model (number of outputs, sensor blocks,
/// control inputs). Throws InputError (see the message format above).
ReplayInput readReplayInput(const std::string& path, const Model& model);
/// Same, from a stream; `source` names it in messages.
ReplayInput parseReplayInput(std::istream& in, const std::string& source, const Model& model);

/// The per-step R columns, last in the header: per sensor, the upper triangle of its block of the
/// stacked R, row by row, as r<a>_<b> (1-based rows a <= b of y), e.g. r1_1,r1_2,r2_2,r3_3.
std::vector<std::string> replayRColumns(const Model& model);
/// Appends a row's r cells (a leading comma each): sensor i's block of R when given[i], else empty.
void writeReplayRowR(std::ostream& os, const Model& model, const Eigen::MatrixXd& R, const std::vector<bool>& given);

/// Header `k,gamma,y1..ym[,u1..up][,nu]` (the r columns: append replayRColumns).
void writeReplayInputHeader(std::ostream& os, int m, int p, bool with_nu,
                            const std::vector<std::string>& r_columns = {});
/// One row. NaN entries of y are written as empty cells, entries marked in `off` (m flags: the
/// rows of a sensor that was not scheduled) as '-'; u is written when non-empty; nu when with_nu.
/// Numbers use %.17g. `tail` (e.g. writeReplayRowR's cells) ends the row.
void writeReplayInputRow(std::ostream& os, long k, bool gamma, const Eigen::VectorXd& y, const Eigen::VectorXd& u,
                         bool with_nu = false, int nu = -1, const std::vector<bool>* off = nullptr,
                         const std::string& tail = "");

// ---------------------------------------------------------------------------------------------
// Replay output

/// Header `k,gamma,x1..xn,P11,P12,...,Pnn,trace`.
void writeReplayOutputHeader(std::ostream& os, int n);
/// One row, numbers with %.17g (round-trip exact doubles).
void writeReplayOutputRow(std::ostream& os, long k, bool gamma, const Eigen::VectorXd& x, const Eigen::MatrixXd& P);

struct ReplayOutputRow
{
  long k = 0;
  bool gamma = true;
  Eigen::VectorXd x;
  Eigen::MatrixXd P;
  double trace = 0.0;
};

struct ReplayOutput
{
  std::string path;
  int n = 0;  ///< state dimension, from the header
  std::vector<ReplayOutputRow> rows;
};

/// Reads a replay output file (n from the header). Throws InputError.
ReplayOutput readReplayOutput(const std::string& path);
ReplayOutput parseReplayOutput(std::istream& in, const std::string& source);

// ---------------------------------------------------------------------------------------------
// Truth (written by simulate)

struct TruthRow
{
  long k = 0;
  Eigen::VectorXd x;
  int nu = 1;  ///< 1 when u_k reached the actuator
};

struct Truth
{
  std::string path;
  int n = 0;
  std::vector<TruthRow> rows;
};

/// Header `k,x1..xn,nu`.
void writeTruthHeader(std::ostream& os, int n);
void writeTruthRow(std::ostream& os, long k, const Eigen::VectorXd& x, bool nu);

/// Reads a truth file (n from the header). Throws InputError.
Truth readTruth(const std::string& path);
Truth parseTruth(std::istream& in, const std::string& source);

// ---------------------------------------------------------------------------------------------
// Helpers

/// %.17g (round-trip exact for every finite double).
std::string formatDouble(double value);

}  // namespace networked_estimation
