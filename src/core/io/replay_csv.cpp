#include "networked_estimation/io/replay_csv.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <istream>
#include <limits>
#include <ostream>
#include <sstream>

#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

namespace
{

const double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---------------------------------------------------------------------------------------------
// Messages

std::string squote(const std::string& text)
{
  return "'" + text + "'";
}

/// `<source>:<line>: <column>: <problem> (expected <expected>, found '<found>')`.
[[noreturn]] void fail(const std::string& source, long line, const std::string& column,
                       const std::string& problem, const std::string& expected, const std::string& found)
{
  std::ostringstream os;
  os << source << ":" << line << ": " << column << ": " << problem << " (expected " << expected << ", found "
     << squote(found) << ")";
  throw InputError(os.str());
}

/// Same, with a found part that is not a cell (e.g. "3 columns").
[[noreturn]] void failRaw(const std::string& source, long line, const std::string& column,
                          const std::string& problem, const std::string& expected, const std::string& found)
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

// ---------------------------------------------------------------------------------------------
// Lines and cells

bool isSpace(char c)
{
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
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
  if (cell.empty())
    return false;
  errno = 0;
  char* end = nullptr;
  const long v = std::strtol(cell.c_str(), &end, 10);
  if (end != cell.c_str() + cell.size() || errno == ERANGE)
    return false;
  out = v;
  return true;
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

void writeNumber(std::ostream& os, double value)
{
  char buf[40];
  const int len = std::snprintf(buf, sizeof buf, "%.17g", value);
  os.write(buf, len);
}

/// A row's r cells: per sensor all empty (the model's R) or all numbers forming a symmetric
/// positive definite block; row.R is the model's R with those blocks (empty when none is given).
void parseRowR(const std::string& source, long line, const Model& model, const std::vector<std::string>& names,
               const std::vector<std::string>& cells, std::size_t r_begin, ReplayRow& row)
{
  std::size_t c = r_begin;
  for (const Sensor& s : model.sensors)
  {
    const std::size_t first = c;
    const int count = s.size * (s.size + 1) / 2;
    int empty = 0;
    for (int i = 0; i < count; ++i)
      empty += cells[first + static_cast<std::size_t>(i)].empty() ? 1 : 0;
    if (empty == count)
    {
      c += static_cast<std::size_t>(count);
      continue;
    }
    if (empty > 0)
    {
      std::size_t e = first;
      while (!cells[e].empty())
        ++e;
      fail(source, line, names[e], "sensor '" + s.name + "' has a partly empty R",
           "all of " + names[first] + ".." + names[first + static_cast<std::size_t>(count) - 1] +
               " empty (the model's R) or all numbers",
           cells[e]);
    }
    Eigen::MatrixXd block(s.size, s.size);
    for (int a = 0; a < s.size; ++a)
      for (int b = a; b < s.size; ++b, ++c)
        block(a, b) = block(b, a) = parseNumber(source, line, names[c], cells[c]);
    if (Eigen::LLT<Eigen::MatrixXd>(block).info() != Eigen::Success)
      failRaw(source, line, names[first], "sensor '" + s.name + "': its R block is not positive definite",
              "a positive definite block", names[first] + ".." + names[c - 1] + " = " + cells[first] + "...");
    if (row.R.size() == 0)
      row.R = model.R;
    row.R.block(s.offset, s.offset, s.size, s.size) = block;
  }
}

}  // namespace

std::vector<std::string> replayRColumns(const Model& model)
{
  std::vector<std::string> names;
  for (const Sensor& s : model.sensors)
    for (int a = s.offset; a < s.offset + s.size; ++a)
      for (int b = a; b < s.offset + s.size; ++b)
        names.push_back("r" + std::to_string(a + 1) + "_" + std::to_string(b + 1));
  return names;
}

void writeReplayRowR(std::ostream& os, const Model& model, const Eigen::MatrixXd& R, const std::vector<bool>& given)
{
  for (std::size_t si = 0; si < model.sensors.size(); ++si)
  {
    const Sensor& s = model.sensors[si];
    for (int a = s.offset; a < s.offset + s.size; ++a)
      for (int b = a; b < s.offset + s.size; ++b)
      {
        os << ',';
        if (R.size() > 0 && si < given.size() && given[si])
          writeNumber(os, R(a, b));
      }
  }
}

// ---------------------------------------------------------------------------------------------
// Helpers

std::string formatDouble(double value)
{
  char buf[40];
  const int len = std::snprintf(buf, sizeof buf, "%.17g", value);
  return std::string(buf, static_cast<std::size_t>(len));
}

// ---------------------------------------------------------------------------------------------
// Replay input

ReplayInput parseReplayInput(std::istream& in, const std::string& source, const Model& model)
{
  const int m = model.m(), p = model.p();
  std::vector<std::string> names = {"k", "gamma"};
  append(names, indexed("y", m));
  const std::size_t y_end = names.size();
  append(names, indexed("u", p));
  const std::size_t u_end = names.size();

  ReplayInput input;
  input.path = source;
  LineReader reader(in, source);
  std::vector<std::string> header =
      readHeader(reader, source, joinNames(names) + "[,nu]");

  // Header: k,gamma,y1..ym, then u1..up (required with control), then an optional nu.
  if (header.empty() || header[0] != "k")
    fail(source, 1, "k", "missing header row", squote(joinNames(names) + "[,nu]"), header.empty() ? "" : header[0]);
  for (std::size_t i = 0; i < u_end; ++i)
  {
    const bool at_u = i >= y_end;
    if (i < header.size() && header[i] == names[i])
      continue;
    if (at_u && (i >= header.size() || header[i] == "nu"))
      failRaw(source, 1, names[i],
              "missing " + (p == 1 ? std::string("column u1") : "columns u1..u" + std::to_string(p)) +
                  ": model has control",
              squote(joinNames(names) + "[,nu]"), i < header.size() ? squote(header[i]) : "end of header");
    if (i >= header.size())
      failRaw(source, 1, names[i], "missing column", squote(joinNames(names) + "[,nu]"), "end of header");
    fail(source, 1, names[i], "unexpected column name", squote(names[i]), header[i]);
  }
  // Then an optional nu, then the optional per-step R columns r<a>_<b> (replayRColumns).
  std::size_t at = u_end;
  if (at < header.size() && header[at] == "nu")
  {
    input.has_nu = true;
    ++at;
  }
  const std::vector<std::string> r_names = replayRColumns(model);
  if (at < header.size() && header[at].size() > 1 && header[at][0] == 'r' && std::isdigit(static_cast<unsigned char>(header[at][1])))
  {
    for (std::size_t i = 0; i < r_names.size(); ++i)
    {
      if (at + i >= header.size())
        failRaw(source, 1, r_names[i], "missing column of the per-step R", squote(joinNames(r_names)), "end of header");
      if (header[at + i] != r_names[i])
        fail(source, 1, r_names[i], "unexpected column name", squote(r_names[i]), header[at + i]);
    }
    input.has_R = true;
    at += r_names.size();
  }
  if (at < header.size())
  {
    const bool looks_like_u = p == 0 && at == u_end && header[at].size() > 1 && header[at][0] == 'u';
    fail(source, 1, header[at],
         looks_like_u ? "unexpected column: model '" + model.name + "' has no control" : "unexpected column",
         at == u_end ? "'nu', r columns or end of header" : input.has_R ? "end of header" : "r columns or end of header",
         header[at]);
  }
  input.has_u = p > 0;
  if (input.has_nu)
    names.push_back("nu");
  const std::size_t r_begin = names.size();
  if (input.has_R)
    append(names, r_names);

  std::vector<std::string> cells;
  long line = 0;
  long expected_k = 1;
  while (reader.next(cells, line))
  {
    checkCount(source, line, cells, names);
    ReplayRow row;
    row.line = line;
    row.k = parseK(source, line, cells[0], expected_k);
    ++expected_k;
    row.gamma = parseFlag(source, line, "gamma", cells[1]);

    row.y.resize(m);
    // A sensor whose cells are all '-' was not scheduled to transmit (not a loss).
    std::vector<bool> off(static_cast<std::size_t>(m), false);
    for (std::size_t si = 0; si < model.sensors.size(); ++si)
    {
      const Sensor& s = model.sensors[si];
      int dashes = 0, first_dash = -1, first_other = -1;
      for (int i = s.offset; i < s.offset + s.size; ++i)
      {
        if (cells[2 + i] == "-")
        {
          ++dashes;
          if (first_dash < 0)
            first_dash = i;
        }
        else if (first_other < 0)
          first_other = i;
      }
      if (dashes > 0 && dashes < s.size)
        fail(source, line, names[2 + first_dash],
             "sensor '" + s.name + "' is partly '-' (" + names[2 + first_other] + " is not)",
             "all of " + names[2 + s.offset] + ".." + names[2 + s.offset + s.size - 1] +
                 " '-' (sensor not scheduled) or none",
             cells[2 + first_dash]);
      if (dashes == s.size)
      {
        if (row.scheduled.empty())
          row.scheduled.assign(model.sensors.size(), true);
        row.scheduled[si] = false;
        for (int i = s.offset; i < s.offset + s.size; ++i)
        {
          off[static_cast<std::size_t>(i)] = true;
          row.y[i] = kNaN;
        }
      }
    }
    if (row.gamma)
    {
      for (const Sensor& s : model.sensors)
      {
        if (off[static_cast<std::size_t>(s.offset)])
          continue;
        int empty = 0;
        int first_empty = -1, first_number = -1;
        for (int i = s.offset; i < s.offset + s.size; ++i)
        {
          const std::string& cell = cells[2 + i];
          const std::string& column = names[2 + i];
          double v = kNaN;
          switch (classify(cell, v))
          {
            case CellKind::EMPTY:
              ++empty;
              if (first_empty < 0)
                first_empty = i;
              row.y[i] = kNaN;
              break;
            case CellKind::NUMBER:
              if (first_number < 0)
                first_number = i;
              row.y[i] = v;
              break;
            case CellKind::NAN_VALUE:
              fail(source, line, column, "nan on a row with gamma = 1; leave all of a lost sensor's cells empty",
                   "a finite number or an empty cell", cell);
            case CellKind::INF_VALUE:
              fail(source, line, column, "not finite on a row with gamma = 1", "a finite number or an empty cell",
                   cell);
            case CellKind::TEXT:
              fail(source, line, column, "not a number on a row with gamma = 1", "a finite number or an empty cell",
                   cell);
          }
        }
        if (empty > 0 && empty < s.size)
          fail(source, line, names[2 + first_empty],
               "sensor '" + s.name + "' is partly empty (" + names[2 + first_number] + " holds a number)",
               "all of " + names[2 + s.offset] + ".." + names[2 + s.offset + s.size - 1] +
                   " empty (sensor lost) or all numbers",
               cells[2 + first_empty]);
      }
    }
    else
    {
      for (int i = 0; i < m; ++i)
      {
        if (off[static_cast<std::size_t>(i)])
          continue;
        const std::string& cell = cells[2 + i];
        double v = kNaN;
        switch (classify(cell, v))
        {
          case CellKind::EMPTY:
          case CellKind::NAN_VALUE:
            row.y[i] = kNaN;
            break;
          case CellKind::NUMBER:
            row.y[i] = v;
            break;
          case CellKind::INF_VALUE:
            fail(source, line, names[2 + i], "not finite", "a finite number, an empty cell or nan", cell);
          case CellKind::TEXT:
            fail(source, line, names[2 + i], "not a number", "a finite number, an empty cell or nan", cell);
        }
      }
    }

    row.u.resize(p);
    for (int j = 0; j < p; ++j)
      row.u[j] = parseNumber(source, line, names[y_end + j], cells[y_end + j]);
    if (input.has_nu)
      row.nu = parseFlag(source, line, "nu", cells[u_end]) ? 1 : 0;
    if (input.has_R)
      parseRowR(source, line, model, names, cells, r_begin, row);
    input.rows.push_back(std::move(row));
  }
  return input;
}

ReplayInput readReplayInput(const std::string& path, const Model& model)
{
  std::ifstream file;
  openInput(file, path);
  return parseReplayInput(file, path, model);
}

void writeReplayInputHeader(std::ostream& os, int m, int p, bool with_nu, const std::vector<std::string>& r_columns)
{
  os << "k,gamma";
  for (int i = 1; i <= m; ++i)
    os << ",y" << i;
  for (int j = 1; j <= p; ++j)
    os << ",u" << j;
  if (with_nu)
    os << ",nu";
  for (const std::string& r : r_columns)
    os << ',' << r;
  os << '\n';
}

void writeReplayInputRow(std::ostream& os, long k, bool gamma, const Eigen::VectorXd& y, const Eigen::VectorXd& u,
                         bool with_nu, int nu, const std::vector<bool>* off, const std::string& tail)
{
  os << k << ',' << (gamma ? '1' : '0');
  for (Eigen::Index i = 0; i < y.size(); ++i)
  {
    os << ',';
    if (off && (*off)[static_cast<std::size_t>(i)])
      os << '-';
    else if (!std::isnan(y[i]))
      writeNumber(os, y[i]);
  }
  for (Eigen::Index j = 0; j < u.size(); ++j)
  {
    os << ',';
    writeNumber(os, u[j]);
  }
  if (with_nu)
    os << ',' << nu;
  os << tail << '\n';
}

// ---------------------------------------------------------------------------------------------
// Replay output

void writeReplayOutputHeader(std::ostream& os, int n)
{
  os << "k,gamma";
  for (int i = 1; i <= n; ++i)
    os << ",x" << i;
  for (int i = 1; i <= n; ++i)
    for (int j = 1; j <= n; ++j)
      os << ",P" << i << j;
  os << ",trace\n";
}

void writeReplayOutputRow(std::ostream& os, long k, bool gamma, const Eigen::VectorXd& x, const Eigen::MatrixXd& P)
{
  os << k << ',' << (gamma ? '1' : '0');
  for (Eigen::Index i = 0; i < x.size(); ++i)
  {
    os << ',';
    writeNumber(os, x[i]);
  }
  for (Eigen::Index i = 0; i < P.rows(); ++i)
    for (Eigen::Index j = 0; j < P.cols(); ++j)
    {
      os << ',';
      writeNumber(os, P(i, j));
    }
  os << ',';
  writeNumber(os, P.trace());
  os << '\n';
}

ReplayOutput parseReplayOutput(std::istream& in, const std::string& source)
{
  ReplayOutput out;
  out.path = source;
  LineReader reader(in, source);
  const std::string shape = "k,gamma,x1..xn,P11..Pnn,trace";
  const std::vector<std::string> header = readHeader(reader, source, shape);
  // 3 + n + n^2 columns.
  int n = 1;
  while (3 + n + n * n < static_cast<int>(header.size()))
    ++n;
  if (3 + n + n * n != static_cast<int>(header.size()))
    failRaw(source, 1, header.empty() ? "k" : header[0], "not a replay output header",
            squote(shape) + " (3 + n + n^2 columns)", std::to_string(header.size()) + " columns");
  std::vector<std::string> names = {"k", "gamma"};
  append(names, indexed("x", n));
  append(names, matrixNames("P", n));
  names.push_back("trace");
  checkHeader(source, header, names);
  out.n = n;

  std::vector<std::string> cells;
  long line = 0;
  long expected_k = 1;
  while (reader.next(cells, line))
  {
    checkCount(source, line, cells, names);
    ReplayOutputRow row;
    row.k = parseK(source, line, cells[0], expected_k++);
    row.gamma = parseFlag(source, line, "gamma", cells[1]);
    row.x.resize(n);
    row.P.resize(n, n);
    for (int i = 0; i < n; ++i)
      row.x[i] = parseNumber(source, line, names[2 + i], cells[2 + i]);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
      {
        const std::size_t c = 2 + n + i * n + j;
        row.P(i, j) = parseNumber(source, line, names[c], cells[c]);
      }
    row.trace = parseNumber(source, line, "trace", cells.back());
    out.rows.push_back(std::move(row));
  }
  return out;
}

ReplayOutput readReplayOutput(const std::string& path)
{
  std::ifstream file;
  openInput(file, path);
  return parseReplayOutput(file, path);
}

// ---------------------------------------------------------------------------------------------
// Truth

void writeTruthHeader(std::ostream& os, int n)
{
  os << "k";
  for (int i = 1; i <= n; ++i)
    os << ",x" << i;
  os << ",nu\n";
}

void writeTruthRow(std::ostream& os, long k, const Eigen::VectorXd& x, bool nu)
{
  os << k;
  for (Eigen::Index i = 0; i < x.size(); ++i)
  {
    os << ',';
    writeNumber(os, x[i]);
  }
  os << ',' << (nu ? '1' : '0') << '\n';
}

Truth parseTruth(std::istream& in, const std::string& source)
{
  Truth truth;
  truth.path = source;
  LineReader reader(in, source);
  const std::string shape = "k,x1..xn,nu";
  const std::vector<std::string> header = readHeader(reader, source, shape);
  if (header.size() < 3)
    failRaw(source, 1, header[0], "not a truth header", squote(shape) + " (at least 3 columns)",
            std::to_string(header.size()) + " column" + (header.size() == 1 ? "" : "s"));
  const int n = static_cast<int>(header.size()) - 2;
  std::vector<std::string> names = {"k"};
  append(names, indexed("x", n));
  names.push_back("nu");
  checkHeader(source, header, names);
  truth.n = n;

  std::vector<std::string> cells;
  long line = 0;
  long expected_k = 1;
  while (reader.next(cells, line))
  {
    checkCount(source, line, cells, names);
    TruthRow row;
    row.k = parseK(source, line, cells[0], expected_k++);
    row.x.resize(n);
    for (int i = 0; i < n; ++i)
      row.x[i] = parseNumber(source, line, names[1 + i], cells[1 + i]);
    row.nu = parseFlag(source, line, "nu", cells.back()) ? 1 : 0;
    truth.rows.push_back(std::move(row));
  }
  return truth;
}

Truth readTruth(const std::string& path)
{
  std::ifstream file;
  openInput(file, path);
  return parseTruth(file, path);
}

}  // namespace networked_estimation
