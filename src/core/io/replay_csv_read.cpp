// Reading the replay input, replay output and truth CSV files (replay_csv.hpp).
#include "networked_estimation/common/numbers.hpp"
#include <cmath>
#include <fstream>
#include <istream>
#include <limits>

#include "io/csv_cells.hpp"
#include "networked_estimation/common/covariance.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/io/replay_csv.hpp"

namespace networked_estimation
{

using namespace csv;

namespace
{

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
    if (!checkCovariance(block, Definiteness::POSITIVE).ok())
      failRaw(source, line, names[first], "sensor '" + s.name + "': its R block is not positive definite",
              "a positive definite block", names[first] + ".." + names[c - 1] + " = " + cells[first] + "...");
    if (row.R.size() == 0)
      row.R = model.R;
    row.R.block(s.offset, s.offset, s.size, s.size) = block;
  }
}

}  // namespace

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
  std::vector<std::string> header = readHeader(reader, source, joinNames(names) + "[,nu]");

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
  if (at < header.size() && header[at].size() > 1 && header[at][0] == 'r' &&
      std::isdigit(static_cast<unsigned char>(header[at][1])))
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
         at == u_end   ? "'nu', r columns or end of header"
         : input.has_R ? "end of header"
                       : "r columns or end of header",
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
