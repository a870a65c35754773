// Lines, cells and messages of the core's CSV readers (csv_cells.hpp).
#include "io/csv_cells.hpp"
#include "io/tokens.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{
namespace csv
{

namespace
{

bool isSpace(char c)
{
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
}

}  // namespace

std::string squote(const std::string& text)
{
  return "'" + text + "'";
}

/// `<source>:<line>: <column>: <problem> (expected <expected>, found '<found>')`.
[[noreturn]] void fail(const std::string& source, long line, const std::string& column, const std::string& problem,
                       const std::string& expected, const std::string& found)
{
  std::ostringstream os;
  os << source << ":" << line << ": " << column << ": " << problem << " (expected " << expected << ", found "
     << squote(found) << ")";
  throw InputError(os.str());
}

/// Same, with a found part that is not a cell (e.g. "3 columns").
[[noreturn]] void failRaw(const std::string& source, long line, const std::string& column, const std::string& problem,
                          const std::string& expected, const std::string& found)
{
  std::ostringstream os;
  os << source << ":" << line << ": " << column << ": " << problem << " (expected " << expected << ", found " << found
     << ")";
  throw InputError(os.str());
}

std::string joinNames(const std::vector<std::string>& names)
{
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i)
  {
    if (i > 0)
      out += ",";
    out += names[i];
  }
  return out;
}

std::string trim(const std::string& text)
{
  std::size_t b = 0, e = text.size();
  while (b < e && isSpace(text[b]))
    ++b;
  while (e > b && isSpace(text[e - 1]))
    --e;
  return text.substr(b, e - b);
}

/// Splits on ',' (keeping empty cells) and trims each cell.
std::vector<std::string> splitCells(const std::string& line)
{
  std::vector<std::string> cells;
  std::size_t start = 0;
  while (true)
  {
    const std::size_t pos = line.find(',', start);
    if (pos == std::string::npos)
    {
      cells.push_back(trim(line.substr(start)));
      return cells;
    }
    cells.push_back(trim(line.substr(start, pos - start)));
    start = pos + 1;
  }
}

CellKind classify(const std::string& cell, double& value)
{
  if (cell.empty())
    return CellKind::EMPTY;
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(cell.c_str(), &end);
  if (end != cell.c_str() + cell.size())
    return CellKind::TEXT;
  if (std::isnan(v))
    return CellKind::NAN_VALUE;
  if (std::isinf(v))
    return CellKind::INF_VALUE;
  value = v;
  return CellKind::NUMBER;
}

bool parseLong(const std::string& cell, long& out)
{
  return tokens::parseLong(cell, out);  // (cells are trimmed: no leading space to refuse)
}

/// Opens a file for reading or throws InputError naming it.
void openInput(std::ifstream& file, const std::string& path)
{
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path + ": cannot open file (it is a directory)");
  errno = 0;
  file.open(path, std::ios::in | std::ios::binary);
  if (!file)
    throw InputError(path + ": cannot open file" + (errno != 0 ? " (" + std::string(std::strerror(errno)) + ")" : ""));
}

/// Checks the column count of a data row.
void checkCount(const std::string& source, long line, const std::vector<std::string>& cells,
                const std::vector<std::string>& header)
{
  const std::size_t have = cells.size(), want = header.size();
  if (have == want)
    return;
  const std::string column = have < want ? header[have] : "column " + std::to_string(want + 1);
  failRaw(source, line, column, have < want ? "missing cells" : "too many cells",
          std::to_string(want) + " columns as in the header",
          std::to_string(have) + " column" + (have == 1 ? "" : "s"));
}

/// k of a row: an integer equal to `expected`.
long parseK(const std::string& source, long line, const std::string& cell, long expected)
{
  long k = 0;
  if (!parseLong(cell, k))
    fail(source, line, "k", "not an integer", std::to_string(expected), cell);
  if (k != expected)
    fail(source, line, "k", "k out of order", std::to_string(expected), cell);
  return k;
}

/// A 0/1 cell.
bool parseFlag(const std::string& source, long line, const std::string& column, const std::string& cell)
{
  if (cell == "0")
    return false;
  if (cell == "1")
    return true;
  fail(source, line, column, "not 0 or 1", "0 or 1", cell);
}

/// A finite number cell.
double parseNumber(const std::string& source, long line, const std::string& column, const std::string& cell)
{
  double v = 0.0;
  switch (classify(cell, v))
  {
    case CellKind::NUMBER:
      return v;
    case CellKind::EMPTY:
      fail(source, line, column, "empty cell", "a finite number", cell);
    case CellKind::NAN_VALUE:
    case CellKind::INF_VALUE:
      fail(source, line, column, "not finite", "a finite number", cell);
    case CellKind::TEXT:
      break;
  }
  fail(source, line, column, "not a number", "a finite number", cell);
}

/// Reads the header row; throws when the file has none.
std::vector<std::string> readHeader(LineReader& reader, const std::string& source, const std::string& expected)
{
  std::vector<std::string> cells;
  long line = 0;
  if (!reader.next(cells, line))
    throw InputError(source + ": empty file (expected a header row '" + expected + "')");
  return cells;
}

/// Compares a header with the expected names, column by column.
void checkHeader(const std::string& source, const std::vector<std::string>& cells,
                 const std::vector<std::string>& names)
{
  for (std::size_t i = 0; i < std::max(cells.size(), names.size()); ++i)
  {
    if (i >= cells.size())
      failRaw(source, 1, names[i], "missing column", squote(joinNames(names)), "end of header");
    if (i >= names.size())
      fail(source, 1, cells[i], "unexpected column", "end of header after " + squote(names.back()), cells[i]);
    if (cells[i] != names[i])
    {
      if (i == 0)
        fail(source, 1, names[0], "missing header row", squote(joinNames(names)), cells[0]);
      fail(source, 1, names[i], "unexpected column name", squote(names[i]), cells[i]);
    }
  }
}

std::vector<std::string> indexed(const std::string& prefix, int count)
{
  std::vector<std::string> names;
  for (int i = 1; i <= count; ++i)
    names.push_back(prefix + std::to_string(i));
  return names;
}

std::vector<std::string> matrixNames(const std::string& prefix, int n)
{
  std::vector<std::string> names;
  for (int i = 1; i <= n; ++i)
    for (int j = 1; j <= n; ++j)
      names.push_back(prefix + std::to_string(i) + std::to_string(j));
  return names;
}

void append(std::vector<std::string>& a, const std::vector<std::string>& b)
{
  a.insert(a.end(), b.begin(), b.end());
}

}  // namespace csv
}  // namespace networked_estimation
