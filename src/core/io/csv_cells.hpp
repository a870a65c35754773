// Private to the core's CSV readers (replay_csv_read.cpp): lines and cells of a CSV file, the
// checks of a header and of a row's cells, and the messages they throw,
//   <source>:<line>: <column>: <problem> (expected <expected>, found '<found>')
// (replay_csv.hpp has the format of the messages).
#pragma once

#include <fstream>
#include <istream>
#include <string>
#include <vector>

#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{
namespace csv
{

std::string squote(const std::string& text);

/// `<source>:<line>: <column>: <problem> (expected <expected>, found '<found>')`.
[[noreturn]] void fail(const std::string& source, long line, const std::string& column, const std::string& problem,
                       const std::string& expected, const std::string& found);
/// Same, with a found part that is not a cell (e.g. "3 columns").
[[noreturn]] void failRaw(const std::string& source, long line, const std::string& column, const std::string& problem,
                          const std::string& expected, const std::string& found);
std::string joinNames(const std::vector<std::string>& names);

std::string trim(const std::string& text);
/// Splits on ',' (keeping empty cells) and trims each cell.
std::vector<std::string> splitCells(const std::string& line);

/// Reads the non-blank lines of a CSV file. CRLF line ends and a UTF-8 byte order mark are
/// tolerated, trailing blank lines are ignored, a blank line followed by more data is an error.
class LineReader
{
public:
  LineReader(std::istream& in, const std::string& source) : in_(in), source_(source) {}

  /// Next non-blank line split into cells; false at the end of the data.
  bool next(std::vector<std::string>& cells, long& line)
  {
    std::string text;
    while (std::getline(in_, text))
    {
      ++line_;
      if (line_ == 1 && text.compare(0, 3, "\xEF\xBB\xBF") == 0)
        text.erase(0, 3);
      if (trim(text).empty())
      {
        if (first_blank_ == 0)
          first_blank_ = line_;
        continue;
      }
      if (first_blank_ != 0)
        fail(source_, first_blank_, "k", "blank line inside the data", "a row (blank lines only at the end)", "");
      cells = splitCells(text);
      line = line_;
      return true;
    }
    if (in_.bad())
      throw InputError(source_ + ": read error");
    return false;
  }

private:
  std::istream& in_;
  const std::string& source_;
  long line_ = 0;
  long first_blank_ = 0;
};

enum class CellKind
{
  EMPTY,
  NUMBER,  ///< a finite number
  NAN_VALUE,
  INF_VALUE,
  TEXT
};

CellKind classify(const std::string& cell, double& value);
bool parseLong(const std::string& cell, long& out);
/// Opens a file for reading or throws InputError naming it.
void openInput(std::ifstream& file, const std::string& path);
/// Checks the column count of a data row.
void checkCount(const std::string& source, long line, const std::vector<std::string>& cells,
                const std::vector<std::string>& header);
/// k of a row: an integer equal to `expected`.
long parseK(const std::string& source, long line, const std::string& cell, long expected);
/// A 0/1 cell.
bool parseFlag(const std::string& source, long line, const std::string& column, const std::string& cell);
/// A finite number cell.
double parseNumber(const std::string& source, long line, const std::string& column, const std::string& cell);
/// Reads the header row; throws when the file has none.
std::vector<std::string> readHeader(LineReader& reader, const std::string& source, const std::string& expected);
/// Compares a header with the expected names, column by column.
void checkHeader(const std::string& source, const std::vector<std::string>& cells,
                 const std::vector<std::string>& names);
/// prefix1 .. prefixN.
std::vector<std::string> indexed(const std::string& prefix, int count);
/// prefix11, prefix12, .. prefixNN.
std::vector<std::string> matrixNames(const std::string& prefix, int n);
void append(std::vector<std::string>& a, const std::vector<std::string>& b);

}  // namespace csv
}  // namespace networked_estimation
