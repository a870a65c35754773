// CSV input/output of the tools (docs/formats.md, "Replay input", "Replay output"), the truth file,
// scoring and AtomicFile.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/io/atomic_file.hpp"
#include "networked_estimation/io/replay_csv.hpp"
#include "networked_estimation/io/score.hpp"
#include "test_support.hpp"

namespace networked_estimation
{
namespace
{

namespace fs = std::filesystem;

/// Two sensors: "left" (1 row) and "right" (2 rows), n = 2, no control.
Model twoSensorModel()
{
  Model m;
  m.name = "two_sensors";
  m.period = 0.01;
  m.A = Eigen::MatrixXd::Identity(2, 2);
  m.B = Eigen::MatrixXd::Identity(2, 2);
  m.Q = Eigen::MatrixXd::Identity(2, 2);
  m.C.resize(3, 2);
  m.C << 1, 0, 0, 1, 1, 1;
  m.R = Eigen::MatrixXd::Identity(3, 3);
  m.x0 = Eigen::VectorXd::Zero(2);
  m.P0 = Eigen::MatrixXd::Identity(2, 2);
  m.sensors = {{"left", 0, 1}, {"right", 1, 2}};
  m.Bu.resize(2, 0);
  validateModel(m, "twoSensorModel");
  return m;
}

ReplayInput parse(const std::string& content, const Model& model)
{
  std::istringstream in(content);
  return parseReplayInput(in, "in.csv", model);
}

/// Expects an InputError whose message starts with "in.csv:<line>: <column>: " and contains `extra`.
void expectInputError(const std::string& content, const Model& model, long line, const std::string& column,
                      const std::string& extra = "")
{
  try
  {
    parse(content, model);
    ADD_FAILURE() << "no InputError for:\n" << content;
  }
  catch (const InputError& e)
  {
    const std::string msg = e.what();
    const std::string prefix = "in.csv:" + std::to_string(line) + ": " + column + ": ";
    EXPECT_EQ(msg.rfind(prefix, 0), 0u) << "message '" << msg << "' does not start with '" << prefix << "'";
    EXPECT_NE(msg.find(extra), std::string::npos) << "message '" << msg << "' lacks '" << extra << "'";
  }
}

bool isNaN(double v)
{
  return std::isnan(v);
}

/// A fresh temporary directory, removed at the end of the test.
class TempDir
{
public:
  TempDir()
  {
    char tmpl[] = "/tmp/test_replay_io.XXXXXX";
    const char* dir = mkdtemp(tmpl);
    if (!dir)
      throw std::runtime_error("mkdtemp failed");
    path_ = dir;
  }
  ~TempDir()
  {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  std::size_t entries() const
  {
    std::size_t count = 0;
    for (auto it = fs::directory_iterator(path_); it != fs::directory_iterator(); ++it)
      ++count;
    return count;
  }

private:
  fs::path path_;
};

void writeFile(const std::string& path, const std::string& content)
{
  std::ofstream f(path, std::ios::binary);
  f << content;
}

// ---------------------------------------------------------------------------------------------
// Good files

TEST(ReplayInput, SingleSensorGoodFile)
{
  const Model model = test::zhouModel();
  const ReplayInput in = parse("k,gamma,y1\n1,1,0.5\n2,0,\n3,0,nan\n4,0,-1.25\n5,1,-3e-2\n", model);
  ASSERT_EQ(in.rows.size(), 5u);
  EXPECT_FALSE(in.has_u);
  EXPECT_FALSE(in.has_nu);
  EXPECT_EQ(in.rows[0].k, 1);
  EXPECT_TRUE(in.rows[0].gamma);
  EXPECT_EQ(in.rows[0].y[0], 0.5);
  EXPECT_EQ(in.rows[0].line, 2);
  EXPECT_EQ(in.rows[0].u.size(), 0);
  EXPECT_EQ(in.rows[0].nu, -1);
  EXPECT_FALSE(in.rows[1].gamma);
  EXPECT_TRUE(isNaN(in.rows[1].y[0]));  // empty
  EXPECT_TRUE(isNaN(in.rows[2].y[0]));  // nan
  EXPECT_EQ(in.rows[4].k, 5);
  EXPECT_EQ(in.rows[4].y[0], -0.03);
}

TEST(ReplayInput, NoiseCellsKeptOnLossRows)
{
  const Model model = twoSensorModel();
  const ReplayInput in = parse("k,gamma,y1,y2,y3\n1,0,0.25,-1.5,2\n2,0,,nan,7\n", model);
  ASSERT_EQ(in.rows.size(), 2u);
  EXPECT_FALSE(in.rows[0].gamma);
  EXPECT_EQ(in.rows[0].y[0], 0.25);  // kf updates with what the papers' model delivers
  EXPECT_EQ(in.rows[0].y[1], -1.5);
  EXPECT_EQ(in.rows[0].y[2], 2.0);
  EXPECT_TRUE(isNaN(in.rows[1].y[0]));
  EXPECT_TRUE(isNaN(in.rows[1].y[1]));
  EXPECT_EQ(in.rows[1].y[2], 7.0);
}

TEST(ReplayInput, PerSensorLoss)
{
  const Model model = twoSensorModel();
  const ReplayInput in = parse(
      "k,gamma,y1,y2,y3\n"
      "1,1,1,2,3\n"
      "2,1,,4,5\n"
      "3,1,6,,\n"
      "4,1,,,\n",
      model);
  ASSERT_EQ(in.rows.size(), 4u);
  EXPECT_EQ(in.rows[0].y, Eigen::Vector3d(1, 2, 3));
  EXPECT_TRUE(isNaN(in.rows[1].y[0]));  // left lost
  EXPECT_EQ(in.rows[1].y[1], 4.0);
  EXPECT_EQ(in.rows[1].y[2], 5.0);
  EXPECT_EQ(in.rows[2].y[0], 6.0);  // right lost
  EXPECT_TRUE(isNaN(in.rows[2].y[1]));
  EXPECT_TRUE(isNaN(in.rows[2].y[2]));
  EXPECT_TRUE(in.rows[3].y.array().isNaN().all());
}

TEST(ReplayInput, CrlfNoTrailingNewlineAndTrailingBlankLines)
{
  const Model model = test::zhouModel();
  EXPECT_EQ(parse("k,gamma,y1\r\n1,1,0.5\r\n2,1,1.5", model).rows.size(), 2u);
  EXPECT_EQ(parse("k,gamma,y1\n1,1,0.5\n2,1,1.5\n\n\r\n  \n", model).rows.size(), 2u);
  EXPECT_EQ(parse("k,gamma,y1\n", model).rows.size(), 0u);
  const ReplayInput in = parse("k,gamma,y1\r\n1,1,0.5\r\n", model);
  EXPECT_EQ(in.rows[0].y[0], 0.5);
}

TEST(ReplayInput, ControlAndNu)
{
  const Model model = test::aoeModel();
  const ReplayInput in = parse("k,gamma,y1,y2,u1,nu\n1,1,1,2,1.5,1\n2,0,,,1.25,0\n", model);
  EXPECT_TRUE(in.has_u);
  EXPECT_TRUE(in.has_nu);
  ASSERT_EQ(in.rows.size(), 2u);
  EXPECT_EQ(in.rows[0].u.size(), 1);
  EXPECT_EQ(in.rows[0].u[0], 1.5);
  EXPECT_EQ(in.rows[0].nu, 1);
  EXPECT_EQ(in.rows[1].u[0], 1.25);
  EXPECT_EQ(in.rows[1].nu, 0);

  const ReplayInput no_nu = parse("k,gamma,y1,y2,u1\n1,1,1,2,1.5\n", model);
  EXPECT_TRUE(no_nu.has_u);
  EXPECT_FALSE(no_nu.has_nu);
  EXPECT_EQ(no_nu.rows[0].nu, -1);

  const ReplayInput zhou_nu = parse("k,gamma,y1,nu\n1,1,1,0\n", test::zhouModel());
  EXPECT_TRUE(zhou_nu.has_nu);
  EXPECT_EQ(zhou_nu.rows[0].nu, 0);
}

TEST(ReplayInput, ReadsFile)
{
  TempDir dir;
  const std::string path = dir.file("in.csv");
  writeFile(path, "k,gamma,y1\n1,1,0.5\n");
  const ReplayInput in = readReplayInput(path, test::zhouModel());
  EXPECT_EQ(in.path, path);
  ASSERT_EQ(in.rows.size(), 1u);
}

// ---------------------------------------------------------------------------------------------
// Errors of the file as a whole

TEST(ReplayInputErrors, MissingFileNamesPath)
{
  const std::string path = "/nonexistent/dir/in.csv";
  try
  {
    readReplayInput(path, test::zhouModel());
    ADD_FAILURE() << "no InputError";
  }
  catch (const InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(ReplayInputErrors, DirectoryNamesPath)
{
  TempDir dir;
  const std::string path = dir.file("");
  try
  {
    readReplayInput(path, test::zhouModel());
    ADD_FAILURE() << "no InputError";
  }
  catch (const InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(ReplayInputErrors, EmptyFileNamesPath)
{
  TempDir dir;
  for (const std::string content : {"", "\n\n", "\r\n"})
  {
    const std::string path = dir.file("empty.csv");
    writeFile(path, content);
    try
    {
      readReplayInput(path, test::zhouModel());
      ADD_FAILURE() << "no InputError";
    }
    catch (const InputError& e)
    {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(path), std::string::npos) << msg;
      EXPECT_NE(msg.find("empty file"), std::string::npos) << msg;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Header errors

TEST(ReplayInputErrors, MissingHeader)
{
  expectInputError("1,1,0.5\n2,1,0.7\n", test::zhouModel(), 1, "k", "missing header row");
}

TEST(ReplayInputErrors, WrongColumnName)
{
  expectInputError("k,gamma,z1\n1,1,0.5\n", test::zhouModel(), 1, "y1", "found 'z1'");
  expectInputError("k,gama,y1\n1,1,0.5\n", test::zhouModel(), 1, "gamma", "found 'gama'");
  expectInputError("k,gamma,y2,y1\n1,1,0.5,1\n", twoSensorModel(), 1, "y1", "found 'y2'");
}

TEST(ReplayInputErrors, MissingYColumn)
{
  expectInputError("k,gamma,y1,y2\n1,1,0.5,1\n", twoSensorModel(), 1, "y3", "missing column");
}

TEST(ReplayInputErrors, ExtraColumn)
{
  expectInputError("k,gamma,y1,extra\n1,1,0.5,1\n", test::zhouModel(), 1, "extra", "unexpected column");
  expectInputError("k,gamma,y1,nu,nu\n1,1,0.5,1,1\n", test::zhouModel(), 1, "nu", "unexpected column");
}

TEST(ReplayInputErrors, UColumnsWithoutControl)
{
  expectInputError("k,gamma,y1,u1\n1,1,0.5,1\n", test::zhouModel(), 1, "u1", "has no control");
}

TEST(ReplayInputErrors, MissingUColumnsWithControl)
{
  const Model model = test::aoeModel();
  expectInputError("k,gamma,y1,y2\n1,1,0.5,1\n", model, 1, "u1", "model has control");
  expectInputError("k,gamma,y1,y2,nu\n1,1,0.5,1,1\n", model, 1, "u1", "model has control");
}

// ---------------------------------------------------------------------------------------------
// Row errors

TEST(ReplayInputErrors, ColumnCount)
{
  const Model model = test::zhouModel();
  expectInputError("k,gamma,y1\n1,1,0.5\n2,1\n", model, 3, "y1", "found 2 columns");
  expectInputError("k,gamma,y1\n1,1,0.5\n2,1,0.5,\n", model, 3, "column 4", "found 4 columns");
}

TEST(ReplayInputErrors, KNotInteger)
{
  expectInputError("k,gamma,y1\n1,1,0.5\n2.0,1,0.5\n", test::zhouModel(), 3, "k", "not an integer");
  expectInputError("k,gamma,y1\nx,1,0.5\n", test::zhouModel(), 2, "k", "found 'x'");
}

TEST(ReplayInputErrors, KOutOfOrder)
{
  const Model model = test::zhouModel();
  expectInputError("k,gamma,y1\n1,1,0\n2,1,0\n3,1,0\n4,1,0\n7,1,0\n", model, 6, "k",
                   "k out of order (expected 5, found '7')");
  expectInputError("k,gamma,y1\n0,1,0\n", model, 2, "k", "expected 1, found '0'");
  expectInputError("k,gamma,y1\n1,1,0\n1,1,0\n", model, 3, "k", "expected 2, found '1'");
}

TEST(ReplayInputErrors, GammaNotFlag)
{
  const Model model = test::zhouModel();
  expectInputError("k,gamma,y1\n1,2,0.5\n", model, 2, "gamma", "found '2'");
  expectInputError("k,gamma,y1\n1,,0.5\n", model, 2, "gamma", "expected 0 or 1");
  expectInputError("k,gamma,y1\n1,true,0.5\n", model, 2, "gamma", "found 'true'");
}

TEST(ReplayInputErrors, TextNanInfOnArrivedRow)
{
  const Model model = twoSensorModel();
  expectInputError("k,gamma,y1,y2,y3\n1,1,1,2,3\n2,1,1,abc,3\n", model, 3, "y2", "found 'abc'");
  expectInputError("k,gamma,y1,y2,y3\n1,1,nan,2,3\n", model, 2, "y1", "found 'nan'");
  expectInputError("k,gamma,y1,y2,y3\n1,1,1,2,NaN\n", model, 2, "y3", "found 'NaN'");
  expectInputError("k,gamma,y1,y2,y3\n1,1,inf,2,3\n", model, 2, "y1", "found 'inf'");
  expectInputError("k,gamma,y1,y2,y3\n1,1,1,-inf,3\n", model, 2, "y2", "not finite");
  expectInputError("k,gamma,y1,y2,y3\n1,1,1,2,1e999\n", model, 2, "y3", "not finite");
  expectInputError("k,gamma,y1,y2,y3\n1,1,1,2,3x\n", model, 2, "y3", "not a number");
}

TEST(ReplayInputErrors, PartlyEmptySensor)
{
  const Model model = twoSensorModel();
  expectInputError("k,gamma,y1,y2,y3\n1,1,1,2,3\n2,1,1,,3\n", model, 3, "y2", "sensor 'right' is partly empty");
  expectInputError("k,gamma,y1,y2,y3\n1,1,1,2,\n", model, 2, "y3", "sensor 'right' is partly empty");
}

TEST(ReplayInputErrors, TextOrInfOnLossRow)
{
  const Model model = test::zhouModel();
  expectInputError("k,gamma,y1\n1,0,abc\n", model, 2, "y1", "not a number");
  expectInputError("k,gamma,y1\n1,0,inf\n", model, 2, "y1", "not finite");
}

TEST(ReplayInputErrors, BadU)
{
  const Model model = test::aoeModel();
  expectInputError("k,gamma,y1,y2,u1\n1,1,1,2,\n", model, 2, "u1", "empty cell");
  expectInputError("k,gamma,y1,y2,u1\n1,1,1,2,1\n2,0,,,abc\n", model, 3, "u1", "found 'abc'");
  expectInputError("k,gamma,y1,y2,u1\n1,1,1,2,nan\n", model, 2, "u1", "not finite");
}

TEST(ReplayInputErrors, BadNu)
{
  const Model model = test::aoeModel();
  expectInputError("k,gamma,y1,y2,u1,nu\n1,1,1,2,1,2\n", model, 2, "nu", "found '2'");
  expectInputError("k,gamma,y1,y2,u1,nu\n1,1,1,2,1,\n", model, 2, "nu", "expected 0 or 1");
}

TEST(ReplayInputErrors, BlankLineInsideData)
{
  expectInputError("k,gamma,y1\n1,1,0.5\n\n3,1,0.5\n", test::zhouModel(), 3, "k", "blank line");
}

TEST(ReplayInputErrors, FileMessageFormat)
{
  TempDir dir;
  const std::string path = dir.file("bad.csv");
  writeFile(path, "k,gamma,y1\n1,1,0\n2,1,0\n3,1,0\n4,1,0\n5,1,0\n6,1,oops\n");
  try
  {
    readReplayInput(path, test::zhouModel());
    ADD_FAILURE() << "no InputError";
  }
  catch (const InputError& e)
  {
    EXPECT_EQ(std::string(e.what()), path +
                                         ":7: y1: not a number on a row with gamma = 1 (expected a finite number or "
                                         "an empty cell, found 'oops')");
  }
}

// ---------------------------------------------------------------------------------------------
// Writers and round trips

TEST(ReplayOutput, RoundTripIsExact)
{
  Rng rng(42);
  const int n = 3;
  std::ostringstream os;
  writeReplayOutputHeader(os, n);
  EXPECT_EQ(os.str(), "k,gamma,x1,x2,x3,P11,P12,P13,P21,P22,P23,P31,P32,P33,trace\n");
  std::vector<Eigen::VectorXd> xs;
  std::vector<Eigen::MatrixXd> Ps;
  for (int k = 1; k <= 50; ++k)
  {
    Eigen::VectorXd x = test::randomMatrix(rng, n, 1, std::pow(10.0, rng.uniform(-300, 300)));
    if (k == 2)
      x << 0.1, 1.0 / 3.0, std::numeric_limits<double>::denorm_min();
    if (k == 3)
      x << std::numeric_limits<double>::max(), -std::numeric_limits<double>::min(), -0.0;
    Eigen::MatrixXd P = test::randomSpd(rng, n) * std::pow(10.0, rng.uniform(-20, 20));
    writeReplayOutputRow(os, k, k % 3 != 0, x, P);
    xs.push_back(x);
    Ps.push_back(P);
  }
  std::istringstream in(os.str());
  const ReplayOutput out = parseReplayOutput(in, "out.csv");
  EXPECT_EQ(out.n, n);
  ASSERT_EQ(out.rows.size(), xs.size());
  for (std::size_t i = 0; i < xs.size(); ++i)
  {
    EXPECT_EQ(out.rows[i].k, static_cast<long>(i + 1));
    EXPECT_EQ(out.rows[i].gamma, (i + 1) % 3 != 0);
    for (int j = 0; j < n; ++j)
      EXPECT_EQ(out.rows[i].x[j], xs[i][j]) << "row " << i;  // bit-exact
    EXPECT_TRUE((out.rows[i].P.array() == Ps[i].array()).all()) << "row " << i;
    EXPECT_EQ(out.rows[i].trace, Ps[i].trace());
  }
  // The sign of -0.0 survives too.
  EXPECT_TRUE(std::signbit(out.rows[2].x[2]));
}

TEST(ReplayOutput, NumbersParseBackWithStrtod)
{
  std::ostringstream os;
  Eigen::VectorXd x(1);
  x << 0.1 + 0.2;
  Eigen::MatrixXd P(1, 1);
  P << 2.0 / 3.0;
  writeReplayOutputRow(os, 7, true, x, P);
  const std::string line = os.str();
  EXPECT_EQ(line.rfind("7,1,", 0), 0u);
  std::vector<double> values;
  std::stringstream ss(line.substr(4));
  std::string cell;
  while (std::getline(ss, cell, ','))
    values.push_back(std::strtod(cell.c_str(), nullptr));
  ASSERT_EQ(values.size(), 3u);
  EXPECT_EQ(values[0], 0.1 + 0.2);
  EXPECT_EQ(values[1], 2.0 / 3.0);
  EXPECT_EQ(values[2], 2.0 / 3.0);
}

TEST(ReplayOutput, BadFiles)
{
  {
    std::istringstream in("k,gamma,x1,x2\n");
    EXPECT_THROW(parseReplayOutput(in, "out.csv"), InputError);
  }
  {
    std::istringstream in("k,gamma,x1,P11,trace\n1,1,0.5,abc,1\n");
    try
    {
      parseReplayOutput(in, "out.csv");
      ADD_FAILURE() << "no InputError";
    }
    catch (const InputError& e)
    {
      EXPECT_EQ(std::string(e.what()).rfind("out.csv:2: P11: ", 0), 0u) << e.what();
    }
  }
}

TEST(ReplayInput, WriterRoundTrip)
{
  const Model model = twoSensorModel();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::ostringstream os;
  writeReplayInputHeader(os, model.m(), model.p(), true);
  writeReplayInputRow(os, 1, true, Eigen::Vector3d(0.1, 1.0 / 3.0, -2e-300), Eigen::VectorXd(), true, 1);
  writeReplayInputRow(os, 2, true, Eigen::Vector3d(nan, 4, 5), Eigen::VectorXd(), true, 0);
  writeReplayInputRow(os, 3, false, Eigen::Vector3d(nan, nan, nan), Eigen::VectorXd(), true, 1);
  EXPECT_EQ(os.str().substr(0, os.str().find('\n')), "k,gamma,y1,y2,y3,nu");
  const ReplayInput in = parse(os.str(), model);
  ASSERT_EQ(in.rows.size(), 3u);
  EXPECT_EQ(in.rows[0].y[1], 1.0 / 3.0);
  EXPECT_EQ(in.rows[0].y[2], -2e-300);
  EXPECT_TRUE(isNaN(in.rows[1].y[0]));
  EXPECT_EQ(in.rows[1].nu, 0);
  EXPECT_TRUE(in.rows[2].y.array().isNaN().all());

  const Model aoe = test::aoeModel();
  std::ostringstream os2;
  writeReplayInputHeader(os2, aoe.m(), aoe.p(), false);
  writeReplayInputRow(os2, 1, true, Eigen::Vector2d(1, 2), Eigen::VectorXd::Constant(1, 1.0 + std::exp(-0.1)));
  const ReplayInput in2 = parse(os2.str(), aoe);
  EXPECT_EQ(in2.rows[0].u[0], 1.0 + std::exp(-0.1));
}

// Per-step R columns (r<a>_<b>: the upper triangle of each sensor's block): a row's blocks replace
// the model's; empty cells keep it; they round-trip through the writer exactly.
TEST(ReplayInput, PerStepRColumns)
{
  const Model model = twoSensorModel();  // left: y1; right: y2, y3
  EXPECT_EQ(replayRColumns(model), (std::vector<std::string>{"r1_1", "r2_2", "r2_3", "r3_3"}));
  const ReplayInput in = parse(
      "k,gamma,y1,y2,y3,r1_1,r2_2,r2_3,r3_3\n"
      "1,1,0.5,1,2,,,,\n"
      "2,1,0.5,1,2,4,2,0.5,3\n"
      "3,1,0.5,-,-,0.25,,,\n",
      model);
  ASSERT_TRUE(in.has_R);
  EXPECT_EQ(in.rows[0].R.size(), 0);  // none given: the model's R
  Eigen::MatrixXd R2(3, 3);
  R2 << 4, 0, 0, 0, 2, 0.5, 0, 0.5, 3;
  EXPECT_EQ(in.rows[1].R, R2);
  Eigen::MatrixXd R3 = model.R;
  R3(0, 0) = 0.25;
  EXPECT_EQ(in.rows[2].R, R3);
  EXPECT_FALSE(in.rows[2].scheduled[1]);

  std::ostringstream os;
  writeReplayInputHeader(os, model.m(), model.p(), false, replayRColumns(model));
  const Eigen::Vector3d y(0.1, 1.0 / 3.0, 2.0);
  Eigen::MatrixXd R = model.R;
  R(1, 2) = R(2, 1) = 1.0 / 7.0;
  R(0, 0) = 0.1;
  std::ostringstream tail;
  writeReplayRowR(tail, model, R, {false, true});
  writeReplayInputRow(os, 1, true, y, Eigen::VectorXd(), false, -1, nullptr, tail.str());
  const ReplayInput back = parse(os.str(), model);
  Eigen::MatrixXd expect = R;
  expect(0, 0) = model.R(0, 0);  // left's block was not given
  EXPECT_EQ(back.rows[0].R, expect);
  EXPECT_EQ(back.rows[0].y, y);
}

TEST(ReplayInputErrors, BadRColumns)
{
  const Model model = twoSensorModel();
  expectInputError("k,gamma,y1,y2,y3,r1_1,r2_2\n1,1,0,0,0,1,1\n", model, 1, "r2_3", "missing column of the per-step R");
  expectInputError("k,gamma,y1,y2,y3,r1_1,r2_2,r3_2,r3_3\n", model, 1, "r2_3", "unexpected column name");
  expectInputError("k,gamma,y1,y2,y3,r1_1,r2_2,r2_3,r3_3,x\n", model, 1, "x", "unexpected column");
  const std::string h = "k,gamma,y1,y2,y3,r1_1,r2_2,r2_3,r3_3\n";
  expectInputError(h + "1,1,0,0,0,1,1,,1\n", model, 2, "r2_3", "sensor 'right' has a partly empty R");
  expectInputError(h + "1,1,0,0,0,1,1,2,1\n", model, 2, "r2_2", "sensor 'right': its R block is not positive definite");
  expectInputError(h + "1,1,0,0,0,-1,,,\n", model, 2, "r1_1", "not positive definite");
  expectInputError(h + "1,1,0,0,0,nan,,,\n", model, 2, "r1_1", "not finite");
  expectInputError(h + "1,1,0,0,0,abc,,,\n", model, 2, "r1_1", "not a number");
}

TEST(Truth, RoundTrip)
{
  std::ostringstream os;
  writeTruthHeader(os, 2);
  writeTruthRow(os, 1, Eigen::Vector2d(0.1, -1.0 / 7.0), true);
  writeTruthRow(os, 2, Eigen::Vector2d(3e100, 0), false);
  EXPECT_EQ(os.str().substr(0, os.str().find('\n')), "k,x1,x2,nu");
  std::istringstream in(os.str());
  const Truth truth = parseTruth(in, "truth.csv");
  EXPECT_EQ(truth.n, 2);
  ASSERT_EQ(truth.rows.size(), 2u);
  EXPECT_EQ(truth.rows[0].x[1], -1.0 / 7.0);
  EXPECT_EQ(truth.rows[0].nu, 1);
  EXPECT_EQ(truth.rows[1].x[0], 3e100);
  EXPECT_EQ(truth.rows[1].nu, 0);

  std::istringstream bad("k,x1,x2,nu\n1,0,0,1\n2,0,0,5\n");
  try
  {
    parseTruth(bad, "truth.csv");
    ADD_FAILURE() << "no InputError";
  }
  catch (const InputError& e)
  {
    EXPECT_EQ(std::string(e.what()).rfind("truth.csv:3: nu: ", 0), 0u) << e.what();
  }
}

// ---------------------------------------------------------------------------------------------
// Scoring

TEST(Score, HandComputed)
{
  Truth truth;
  truth.n = 1;
  ReplayOutput est;
  est.n = 1;
  for (int k = 1; k <= 4; ++k)
  {
    truth.rows.push_back({k, Eigen::VectorXd::Constant(1, k), 1});
    ReplayOutputRow row;
    row.k = k;
    row.gamma = k != 2;
    row.x = Eigen::VectorXd::Constant(1, k + (k % 2 == 0 ? 1.0 : 2.0));  // errors 2, 1, 2, 1
    row.P = Eigen::MatrixXd::Constant(1, 1, k);
    row.trace = k;
    est.rows.push_back(row);
  }
  const Score all = scoreEstimate("a", truth, est, 1);
  EXPECT_EQ(all.name, "a");
  EXPECT_EQ(all.steps, 4);
  EXPECT_DOUBLE_EQ(all.arrival_rate, 0.75);
  EXPECT_DOUBLE_EQ(all.mse, (4.0 + 1.0 + 4.0 + 1.0) / 4.0);
  EXPECT_DOUBLE_EQ(all.mean_trace, 2.5);
  EXPECT_DOUBLE_EQ(all.ratio, 1.0);
  const Score late = scoreEstimate("a", truth, est, 3);
  EXPECT_EQ(late.steps, 2);
  EXPECT_DOUBLE_EQ(late.arrival_rate, 1.0);
  EXPECT_DOUBLE_EQ(late.mse, 2.5);
  EXPECT_DOUBLE_EQ(late.mean_trace, 3.5);

  EXPECT_THROW(scoreEstimate("a", truth, est, 5), InputError);
  ReplayOutput shorter = est;
  shorter.rows.pop_back();
  EXPECT_THROW(scoreEstimate("a", truth, shorter, 1), InputError);
  ReplayOutput wide = est;
  wide.n = 2;
  EXPECT_THROW(scoreEstimate("a", truth, wide, 1), InputError);

  const std::string table = formatScores({all, late}, 1, false);
  EXPECT_NE(table.find("a "), std::string::npos) << table;
  const std::string csv = formatScores({all}, 1, true);
  EXPECT_EQ(csv, "name,steps,arrival_rate,mse,mean_trace,ratio\na,4,0.75,2.5,2.5,1\n");
}

// ---------------------------------------------------------------------------------------------
// AtomicFile

TEST(AtomicFile, NothingLeftWhenNotCommitted)
{
  TempDir dir;
  const std::string path = dir.file("out.csv");
  {
    AtomicFile f(path);
    f.stream() << "partial";
    EXPECT_TRUE(fs::exists(f.tempPath()));
    EXPECT_EQ(fs::path(f.tempPath()).parent_path(), fs::path(path).parent_path());
    EXPECT_FALSE(fs::exists(path));
  }
  EXPECT_FALSE(fs::exists(path));
  EXPECT_EQ(dir.entries(), 0u);
}

TEST(AtomicFile, ExceptionLeavesOldFileUntouched)
{
  TempDir dir;
  const std::string path = dir.file("out.csv");
  writeFile(path, "old\n");
  try
  {
    AtomicFile f(path);
    f.stream() << "new, partial";
    throw InputError("bad row");
  }
  catch (const InputError&)
  {
  }
  std::ifstream in(path);
  std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(content, "old\n");
  EXPECT_EQ(dir.entries(), 1u);
}

TEST(AtomicFile, CommitReplacesTarget)
{
  TempDir dir;
  const std::string path = dir.file("out.csv");
  writeFile(path, "old\n");
  {
    AtomicFile f(path);
    f.stream() << "new\n";
    f.commit();
    EXPECT_TRUE(f.committed());
    EXPECT_FALSE(fs::exists(f.tempPath()));
  }
  std::ifstream in(path);
  std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(content, "new\n");
  EXPECT_EQ(dir.entries(), 1u);
}

TEST(AtomicFile, UncreatableNamesPath)
{
  const std::string path = "/nonexistent/dir/out.csv";
  try
  {
    AtomicFile f(path);
    ADD_FAILURE() << "no InputError";
  }
  catch (const InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(AtomicFile, FailedRenameRemovesTemp)
{
  TempDir dir;
  const std::string target = dir.file("sub");
  fs::create_directory(target);
  fs::create_directory(target + "/x");  // a non-empty directory cannot be replaced by a file
  {
    AtomicFile f(target);
    f.stream() << "data\n";
    EXPECT_THROW(f.commit(), InputError);
    EXPECT_FALSE(fs::exists(f.tempPath()));
  }
  EXPECT_EQ(dir.entries(), 1u);
}

}  // namespace
}  // namespace networked_estimation
