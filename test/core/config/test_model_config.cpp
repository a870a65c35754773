// Tests of parseModel, loadModel and validateModel (config/model.hpp).
#include "config_test_support.hpp"

// =============================================================================================
// Model: accepted files
// =============================================================================================

TEST(ParseModel, ZhouExample)
{
  const ne::Model m = ne::parseModel(YAML::Load(kZhou), "zhou.yaml");
  EXPECT_EQ(m.name, "zhou_example");
  EXPECT_DOUBLE_EQ(m.period, 0.01);
  ASSERT_EQ(m.n(), 2);
  ASSERT_EQ(m.nw(), 2);
  ASSERT_EQ(m.m(), 1);
  EXPECT_EQ(m.p(), 0);
  EXPECT_FALSE(m.hasControl());
  ASSERT_EQ(m.ne(), 1);
  Eigen::Matrix2d A;
  A << 0.9802, 0.0196, 0.0, 0.9802;
  EXPECT_TRUE(m.A.isApprox(A, 0.0)) << m.A;
  EXPECT_TRUE(m.B.isIdentity(0.0));
  Eigen::Matrix2d Q;
  Q << 1.9608, 0.0195, 0.0195, 1.9605;
  EXPECT_EQ(m.Q, Eigen::MatrixXd(Q));
  ASSERT_EQ(m.C.rows(), 1);
  ASSERT_EQ(m.C.cols(), 2);
  EXPECT_EQ(m.C(0, 0), 1.0);
  EXPECT_EQ(m.C(0, 1), -1.0);
  ASSERT_EQ(m.R.rows(), 1);
  EXPECT_EQ(m.R(0, 0), 1.0);
  ASSERT_EQ(m.x0.size(), 2);
  EXPECT_EQ(m.x0(0), 1.0);
  EXPECT_EQ(m.x0(1), 0.0);
  EXPECT_TRUE(m.P0.isIdentity(0.0));
  ASSERT_EQ(m.sensors.size(), 1u);
  EXPECT_EQ(m.sensors[0].name, "y");
  EXPECT_EQ(m.sensors[0].offset, 0);
  EXPECT_EQ(m.sensors[0].size, 1);
  const ne::Uncertainty& u = m.uncertainty[0];
  EXPECT_DOUBLE_EQ(u.range, 1.0);
  ASSERT_EQ(u.dA.rows(), 2);
  ASSERT_EQ(u.dA.cols(), 2);
  EXPECT_EQ(u.dA(0, 1), 0.099);
  EXPECT_EQ(u.dA(0, 0), 0.0);
  EXPECT_EQ(u.dA(1, 0), 0.0);
  EXPECT_EQ(u.dA(1, 1), 0.0);
  // absent dB / dC are zero of the right size
  ASSERT_EQ(u.dB.rows(), 2);
  ASSERT_EQ(u.dB.cols(), 2);
  EXPECT_TRUE(u.dB.isZero(0.0));
  ASSERT_EQ(u.dC.rows(), 1);
  ASSERT_EQ(u.dC.cols(), 2);
  EXPECT_TRUE(u.dC.isZero(0.0));
  ASSERT_EQ(m.Bu.rows(), 2);
  EXPECT_EQ(m.Bu.cols(), 0);
}

TEST(ParseModel, Defaults)
{
  const ne::Model m = ne::parseModel(YAML::Load("A: [[0.5, 1, 0], [0, 0.5, 0], [0, 0, 0.2]]\n"
                                                "Q: [[1, 0, 0], [0, 2, 0], [0, 0, 3]]\n"
                                                "C: [[1, 0, 0]]\n"
                                                "R: [[0.25]]\n"
                                                "uncertainty:\n"
                                                "  - {}\n"),
                                     "m.yaml");
  EXPECT_EQ(m.name, "");
  EXPECT_EQ(m.period, 0.0);
  ASSERT_EQ(m.n(), 3);
  EXPECT_EQ(m.B.rows(), 3);
  EXPECT_EQ(m.B.cols(), 3);
  EXPECT_TRUE(m.B.isIdentity(0.0));
  ASSERT_EQ(m.x0.size(), 3);
  EXPECT_TRUE(m.x0.isZero(0.0));
  EXPECT_EQ(m.P0.rows(), 3);
  EXPECT_TRUE(m.P0.isIdentity(0.0));
  EXPECT_EQ(m.Bu.rows(), 3);
  EXPECT_EQ(m.Bu.cols(), 0);
  EXPECT_FALSE(m.hasControl());
  EXPECT_EQ(m.Q(2, 2), 3.0);
  EXPECT_EQ(m.R(0, 0), 0.25);
  ASSERT_EQ(m.ne(), 1);
  const ne::Uncertainty& u = m.uncertainty[0];
  EXPECT_EQ(u.range, 0.0);
  EXPECT_EQ(u.dA.rows(), 3);
  EXPECT_EQ(u.dA.cols(), 3);
  EXPECT_TRUE(u.dA.isZero(0.0));
  EXPECT_EQ(u.dB.rows(), 3);
  EXPECT_EQ(u.dB.cols(), 3);
  EXPECT_TRUE(u.dB.isZero(0.0));
  EXPECT_EQ(u.dC.rows(), 1);
  EXPECT_EQ(u.dC.cols(), 3);
  EXPECT_TRUE(u.dC.isZero(0.0));
}

TEST(ParseModel, MultiSensorStacksCAndR)
{
  const ne::Model m = ne::parseModel(YAML::Load(modelYaml({{"C", kRemove},
                                                           {"R", kRemove},
                                                           {"sensors",
                                                            "[{name: left,  C: [[1, 0]], R: [[0.5]]},"
                                                            " {name: right, C: [[0, 1]], R: [[0.7]]}]"}})),
                                     "m.yaml");
  ASSERT_EQ(m.m(), 2);
  Eigen::Matrix2d C;
  C << 1, 0, 0, 1;
  EXPECT_EQ(m.C, Eigen::MatrixXd(C));
  Eigen::Matrix2d R;
  R << 0.5, 0, 0, 0.7;
  EXPECT_EQ(m.R, Eigen::MatrixXd(R));
  ASSERT_EQ(m.sensors.size(), 2u);
  EXPECT_EQ(m.sensors[0].name, "left");
  EXPECT_EQ(m.sensors[0].offset, 0);
  EXPECT_EQ(m.sensors[0].size, 1);
  EXPECT_EQ(m.sensors[1].name, "right");
  EXPECT_EQ(m.sensors[1].offset, 1);
  EXPECT_EQ(m.sensors[1].size, 1);
}

TEST(ParseModel, MultiSensorWithBlocksOfDifferentSizes)
{
  const ne::Model m =
      ne::parseModel(YAML::Load(modelYaml({{"C", kRemove},
                                           {"R", kRemove},
                                           {"sensors",
                                            "[{name: a, C: [[1, 0], [0, 1]], R: [[2, 0.5], [0.5, 1]]},"
                                            " {name: b, C: [[1, 1]], R: [[3]]}]"},
                                           {"uncertainty", "[{dC: [[0, 1], [0, 0], [1, 0]], range: 0.5}]"}})),
                     "m.yaml");
  ASSERT_EQ(m.m(), 3);
  EXPECT_EQ(m.sensors[1].offset, 2);
  EXPECT_EQ(m.sensors[1].size, 1);
  EXPECT_EQ(m.R(0, 1), 0.5);
  EXPECT_EQ(m.R(2, 2), 3.0);
  EXPECT_EQ(m.R(0, 2), 0.0);
  EXPECT_EQ(m.R(2, 1), 0.0);
  EXPECT_EQ(m.C(2, 0), 1.0);
  EXPECT_EQ(m.C(2, 1), 1.0);
  EXPECT_EQ(m.uncertainty[0].dC(2, 0), 1.0);
}

TEST(ParseModel, ControlAndNonSquareB)
{
  const ne::Model m = ne::parseModel(YAML::Load(modelYaml({{"B", "[[1], [0.5]]"},
                                                           {"Q", "[[2]]"},
                                                           {"control", "{Bu: [[-1], [1]]}"},
                                                           {"uncertainty", "[{dB: [[0], [1]]}]"}})),
                                     "m.yaml");
  EXPECT_EQ(m.nw(), 1);
  EXPECT_EQ(m.B(1, 0), 0.5);
  EXPECT_EQ(m.Q(0, 0), 2.0);
  EXPECT_TRUE(m.hasControl());
  ASSERT_EQ(m.p(), 1);
  EXPECT_EQ(m.Bu(0, 0), -1.0);
  EXPECT_EQ(m.Bu(1, 0), 1.0);
  EXPECT_EQ(m.uncertainty[0].dB(1, 0), 1.0);
  EXPECT_EQ(m.uncertainty[0].dB.cols(), 1);
}

TEST(ParseModel, SingularP0IsAccepted)
{
  const ne::Model m = ne::parseModel(YAML::Load(modelYaml({{"P0", "[[0, 0], [0, 0]]"}})), "m.yaml");
  EXPECT_TRUE(m.P0.isZero(0.0));
}

// =============================================================================================
// Model: rejected files
// =============================================================================================

TEST(ParseModelErrors, MessageShapeWithLine)
{
  // Q is on line 5 of modelYaml.
  const std::string msg = modelError(modelYaml({{"Q", "[[1, 0.5], [0.4, 1]]"}}));
  EXPECT_EQ(msg, "m.yaml:5: Q: not symmetric (Q(0,1) = 0.5 but Q(1,0) = 0.4)");
}

TEST(ParseModelErrors, WrongDimensions)
{
  expectModelError({{"Q", "[[1, 0, 0], [0, 1, 0]]"}}, "Q", "expected 2x2");
  expectModelError({{"Q", "[[1, 0, 0], [0, 1, 0]]"}}, "Q", "found 2x3");
  expectModelError({{"A", "[[1, 0, 0], [0, 1, 0]]"}}, "A", "expected a square matrix");
  expectModelError({{"B", "[[1, 0], [0, 1], [1, 1]]"}}, "B", "expected 2x2 (n = 2 rows), found 3x2");
  expectModelError({{"C", "[[1, 0, 1]]"}}, "C", "expected 1x2 (n = 2 columns), found 1x3");
  expectModelError({{"R", "[[1, 0], [0, 1]]"}}, "R", "expected 1x1");
  expectModelError({{"P0", "[[1]]"}}, "P0", "expected 2x2");
  expectModelError({{"x0", "[1, 2, 3]"}}, "x0", "expected 2 entries");
  expectModelError({{"control", "{Bu: [[1]]}"}}, "control.Bu", "expected 2x1 (n = 2 rows), found 1x1");
  // Q follows the columns of B
  expectModelError({{"B", "[[1], [1]]"}}, "Q", "expected 1x1 (nw = 1");
}

TEST(ParseModelErrors, UncertaintyDimensions)
{
  expectModelError({{"uncertainty", "[{dA: [[1]]}]"}}, "uncertainty[0].dA", "expected 2x2");
  expectModelError({{"uncertainty", "[{dA: [[0, 0], [0, 0]]}, {dB: [[1, 0]]}]"}}, "uncertainty[1].dB", "expected 2x2");
  expectModelError({{"uncertainty", "[{dC: [[1, 0], [0, 1]]}]"}}, "uncertainty[0].dC", "expected 1x2");
}

TEST(ParseModelErrors, RaggedRows)
{
  expectModelError({{"A", "[[1, 0], [0]]"}}, "A", "ragged rows (row 0 has 2 entries, row 1 has 1)");
}

TEST(ParseModelErrors, NonNumericEntry)
{
  expectModelError({{"A", "[[1, abc], [0, 1]]"}}, "A", "expected a number, found 'abc'");
  expectModelError({{"x0", "[0, zero]"}}, "x0", "expected a number, found 'zero'");
  expectModelError({{"A", "[[1, [2]], [0, 1]]"}}, "A", "expected a number, found a list");
}

TEST(ParseModelErrors, NotAMatrix)
{
  expectModelError({{"R", "1"}}, "R", "expected a matrix (list of rows), found '1'");
  expectModelError({{"A", "[1, 0]"}}, "A", "row 0: expected a list of numbers");
  expectModelError({{"x0", "[[1], [0]]"}}, "x0", "expected a number, found a list");
  expectModelError({{"B", "~"}}, "B", "found null");
}

TEST(ParseModelErrors, NanAndInf)
{
  expectModelError({{"A", "[[.nan, 0], [0, 1]]"}}, "A", "not finite");
  expectModelError({{"Q", "[[.inf, 0], [0, 1]]"}}, "Q", "not finite");
  expectModelError({{"x0", "[0, -.inf]"}}, "x0", "not finite");
  expectModelError({{"period", ".nan"}}, "period", "expected a finite number");
}

TEST(ParseModelErrors, NotSymmetric)
{
  expectModelError({{"Q", "[[1, 0.5], [0.4, 1]]"}}, "Q", "not symmetric (Q(0,1) = 0.5 but Q(1,0) = 0.4)");
  expectModelError({{"C", "[[1, 0], [0, 1]]"}, {"R", "[[1, 0.1], [0, 1]]"}}, "R", "not symmetric");
  expectModelError({{"P0", "[[1, 0], [0.2, 1]]"}}, "P0", "not symmetric");
}

TEST(ParseModelErrors, SymmetryToleranceIsRelative)
{
  // A relative asymmetry of 1e-12 is accepted.
  EXPECT_NO_THROW(ne::parseModel(YAML::Load(modelYaml({{"Q", "[[1000, 1], [1.000000000001, 1000]]"}})), "m.yaml"));
}

TEST(ParseModelErrors, NotPositiveDefinite)
{
  expectModelError({{"Q", "[[1, 0], [0, -0.5]]"}}, "Q", "not positive definite (smallest eigenvalue -0.5)");
  expectModelError({{"Q", "[[1, 1], [1, 1]]"}}, "Q", "not positive definite");
  expectModelError({{"R", "[[0]]"}}, "R", "not positive definite (smallest eigenvalue 0");
  expectModelError({{"P0", "[[1, 0], [0, -0.5]]"}}, "P0", "not positive semidefinite (smallest eigenvalue -0.5)");
}

// The strict test is on Q scaled to unit diagonal (D^-1/2 Q D^-1/2, D = diag(Q)): positive
// definiteness does not depend on the units of the variables, and Cholesky's accuracy depends on
// the scaled matrix only. A badly scaled matrix whose eigenvalues span more than 12 orders of
// magnitude is accepted when its correlation matrix is well conditioned; one that is near-singular
// after scaling, or indefinite, is refused.
TEST(ParseModelErrors, DefinitenessIsScaleAware)
{
  const auto accepted = [](const std::string& q)
  {
    SCOPED_TRACE(q);
    EXPECT_NO_THROW(ne::parseModel(YAML::Load(modelYaml({{"Q", q}})), "m.yaml"));
    EXPECT_NO_THROW(ne::parseModel(YAML::Load(modelYaml({{"R", "[[1e-14]]"}, {"Q", q}})), "m.yaml"));
  };
  // Eigenvalue ratio 1e-14 (refused before), correlation matrix I.
  accepted("[[1, 0], [0, 1e-14]]");
  accepted("[[1e-20, 0], [0, 1e10]]");
  // Correlation 0.99 between variables of variance 1e-14 and 1: smallest eigenvalue about 2e-16
  // (ratio 2e-16), scaled eigenvalues 0.01 and 1.99.
  accepted("[[1e-14, 0.99e-7], [0.99e-7, 1]]");
  // A matrix the unscaled test accepted is still accepted.
  accepted("[[1, 0], [0, 1e-11]]");

  // Near-singular after scaling (correlation 1 - 1e-14): refused, well scaled or not.
  // (the message of docs/formats.md 1.2; the smallest eigenvalue, 1e-14, is computed to about 4e-16)
  const std::string unit = modelError(modelYaml({{"Q", "[[1, 0.99999999999999], [0.99999999999999, 1]]"}}));
  EXPECT_CONTAINS(unit, "m.yaml:5: Q: not positive definite (smallest eigenvalue 1");
  EXPECT_CONTAINS(unit, "e-14, largest 2); scaled to unit diagonal it is near-singular too (smallest eigenvalue 1");
  const std::string near = modelError(modelYaml({{"Q", "[[1e-14, 0.99999999999999e-7], [0.99999999999999e-7, 1]]"}}));
  EXPECT_CONTAINS(near, "Q: not positive definite (smallest eigenvalue ");
  EXPECT_CONTAINS(near, "; scaled to unit diagonal it is near-singular too (smallest eigenvalue ");
  // Indefinite (correlation 2), badly scaled: refused, naming the negative eigenvalue.
  expectModelError({{"Q", "[[1e-14, 2e-7], [2e-7, 1]]"}}, "Q", "not positive definite (smallest eigenvalue -");
  expectModelError({{"Q", "[[1, 2], [2, 1]]"}}, "Q", "not positive definite (smallest eigenvalue -1)");
  // A zero or negative diagonal entry is never positive definite (no scaling exists).
  expectModelError({{"Q", "[[1, 0], [0, 0]]"}}, "Q", "not positive definite (smallest eigenvalue 0, largest 1)");
  expectModelError({{"Q", "[[1e-14, 0], [0, -1e-30]]"}}, "Q", "not positive definite (smallest eigenvalue -1e-30)");
  // The semidefinite test of P0 is unchanged: a singular P0 is accepted, an indefinite one refused.
  EXPECT_NO_THROW(ne::parseModel(YAML::Load(modelYaml({{"P0", "[[1, 1], [1, 1]]"}})), "m.yaml"));
  expectModelError({{"P0", "[[1, 2], [2, 1]]"}}, "P0", "not positive semidefinite (smallest eigenvalue -1)");
}

TEST(ParseModelErrors, UnknownKeys)
{
  expectModelError({{"foo", "1"}}, "foo", "unknown key");
  expectModelError({{"uncertainty", "[{dA: [[0, 0], [0, 0]], rnage: 1}]"}}, "uncertainty[0].rnage", "unknown key");
  expectModelError({{"control", "{Bu: [[1], [0]], u: 1}"}}, "control.u", "unknown key");
  expectModelError({{"C", kRemove}, {"R", kRemove}, {"sensors", "[{name: a, C: [[1, 0]], R: [[1]], rate: 10}]"}},
                   "sensors[0].rate", "unknown key");
  // the line of the unknown key is reported (appended key is on line 10)
  EXPECT_CONTAINS(modelError(modelYaml({{"foo", "1"}})), "m.yaml:10: foo: unknown key");
}

TEST(ParseModelErrors, MissingRequiredKeys)
{
  expectModelError({{"A", kRemove}}, "A", "missing required key");
  expectModelError({{"Q", kRemove}}, "Q", "missing required key");
  expectModelError({{"C", kRemove}, {"R", kRemove}}, "C", "missing required key");
  expectModelError({{"R", kRemove}}, "R", "missing required key");
  expectModelError({{"C", kRemove}}, "C", "missing required key");
  expectModelError({{"control", "{}"}}, "control.Bu", "missing required key");
}

TEST(ParseModelErrors, SensorsAndCRTogether)
{
  expectModelError({{"sensors", "[{name: a, C: [[1, 0]], R: [[1]]}]"}}, "sensors", "cannot be combined with C/R");
}

TEST(ParseModelErrors, SensorEntries)
{
  const auto sensors = [](const std::string& list) {
    return std::vector<std::pair<std::string, std::string>>{{"C", kRemove}, {"R", kRemove}, {"sensors", list}};
  };
  expectModelError(sensors("[{name: a, C: [[1, 0]], R: [[1]]}, {name: b, C: [[1, 0, 0]], R: [[1]]}]"), "sensors[1].C",
                   "expected 1x2 (n = 2 columns), found 1x3");
  expectModelError(sensors("[{name: a, C: [[1, 0]], R: [[1]]}, {name: b, C: [[0, 1]], R: [[1, 0], [0, 1]]}]"),
                   "sensors[1].R", "expected 1x1");
  expectModelError(sensors("[{name: a, C: [[1, 0]], R: [[-1]]}]"), "sensors[0].R", "not positive definite");
  expectModelError(sensors("[{name: a, C: [[1, 0], [0, 1]], R: [[1, 2], [3, 1]]}]"), "sensors[0].R", "not symmetric");
  expectModelError(sensors("[{name: a, C: [[1, 0]], R: [[1]]}, {name: a, C: [[0, 1]], R: [[1]]}]"), "sensors[1].name",
                   "duplicate sensor name 'a'");
  expectModelError(sensors("[{name: '', C: [[1, 0]], R: [[1]]}]"), "sensors[0].name", "must not be empty");
  expectModelError(sensors("[{C: [[1, 0]], R: [[1]]}]"), "sensors[0].name", "missing required key");
  expectModelError(sensors("[{name: a, C: [[1, 0]]}]"), "sensors[0].R", "missing required key");
  expectModelError(sensors("[]"), "sensors", "expected a non-empty list");
  expectModelError(sensors("[[1, 0]]"), "sensors[0]", "expected a map");
}

TEST(ParseModelErrors, EmptyMatrices)
{
  expectModelError({{"A", "[]"}}, "A", "empty matrix");
  expectModelError({{"Q", "[[], []]"}}, "Q", "row 0 is empty");
  expectModelError({{"control", "{Bu: []}"}}, "control.Bu", "empty matrix");
}

TEST(ParseModelErrors, NegativeRange)
{
  expectModelError({{"uncertainty", "[{dA: [[0, 1], [0, 0]], range: -1}]"}}, "uncertainty[0].range",
                   "expected a non-negative number, found -1");
  expectModelError({{"uncertainty", "[{range: abc}]"}}, "uncertainty[0].range", "expected a number, found 'abc'");
}

TEST(ParseModelErrors, NonPositivePeriod)
{
  expectModelError({{"period", "0"}}, "period", "expected a positive number of seconds, found 0");
  expectModelError({{"period", "-0.01"}}, "period", "expected a positive number");
  expectModelError({{"period", "fast"}}, "period", "expected a number, found 'fast'");
}

TEST(ParseModelErrors, WrongTypes)
{
  expectModelError({{"name", "[a, b]"}}, "name", "expected a string, found a list");
  expectModelError({{"uncertainty", "{dA: [[0, 0], [0, 0]]}"}}, "uncertainty", "expected a list");
  expectModelError({{"control", "[[1], [0]]"}}, "control", "expected a map");
}

TEST(ParseModelErrors, TopLevel)
{
  EXPECT_CONTAINS(modelError("[1, 2]"), "expected a map of keys at the top level, found a list");
  EXPECT_CONTAINS(modelError(""), "m.yaml: empty document");
}

TEST(ParseModelErrors, DuplicateKey)
{
  expectMessage(modelError(modelYaml() + "A: [[1, 0], [0, 1]]\n"), "m.yaml", "A", "duplicate key");
}

// =============================================================================================
// validateModel on hand-built models
// =============================================================================================

ne::Model handBuilt()
{
  ne::Model m;
  m.A = Eigen::MatrixXd::Identity(2, 2);
  m.B = Eigen::MatrixXd::Identity(2, 2);
  m.Q = Eigen::MatrixXd::Identity(2, 2);
  m.C = Eigen::MatrixXd::Identity(2, 2);
  m.R = Eigen::MatrixXd::Identity(2, 2);
  m.x0 = Eigen::VectorXd::Zero(2);
  m.P0 = Eigen::MatrixXd::Identity(2, 2);
  m.sensors = {{"a", 0, 1}, {"b", 1, 1}};
  m.Bu = Eigen::MatrixXd::Zero(2, 0);
  return m;
}

std::string validateError(const ne::Model& m)
{
  return errorOf([&] { ne::validateModel(m, "hand"); });
}

TEST(ValidateModel, AcceptsValidModel)
{
  EXPECT_NO_THROW(ne::validateModel(handBuilt(), "hand"));
}

TEST(ValidateModel, RejectsBrokenModels)
{
  ne::Model m = handBuilt();
  m.Q(0, 1) = 0.3;
  expectMessage(validateError(m), "hand", "Q", "not symmetric");

  m = handBuilt();
  m.R(1, 1) = -1.0;
  expectMessage(validateError(m), "hand", "R", "not positive definite (smallest eigenvalue -1)");

  // validateModel shares the scale-aware test of parseModel.
  m = handBuilt();
  m.R << 1, 0, 0, 1e-14;
  EXPECT_NO_THROW(ne::validateModel(m, "hand"));
  m.R << 1, 1 - 1e-14, 1 - 1e-14, 1;
  expectMessage(validateError(m), "hand", "R", "scaled to unit diagonal it is near-singular too");

  m = handBuilt();
  m.A(0, 0) = std::numeric_limits<double>::quiet_NaN();
  expectMessage(validateError(m), "hand", "A", "not finite");

  m = handBuilt();
  m.x0 = Eigen::VectorXd::Zero(3);
  expectMessage(validateError(m), "hand", "x0", "expected 2 entries");

  m = handBuilt();
  m.Bu = Eigen::MatrixXd();
  expectMessage(validateError(m), "hand", "control.Bu", "expected 2 rows");

  m = handBuilt();
  m.sensors[1].offset = 0;
  expectMessage(validateError(m), "hand", "sensors[1]", "expected offset 1");

  m = handBuilt();
  m.sensors[1].name = "a";
  expectMessage(validateError(m), "hand", "sensors[1].name", "duplicate sensor name");

  m = handBuilt();
  m.R(0, 1) = m.R(1, 0) = 0.1;
  expectMessage(validateError(m), "hand", "R", "not block diagonal");

  m = handBuilt();
  m.uncertainty.push_back({Eigen::MatrixXd::Zero(2, 2), Eigen::MatrixXd::Zero(2, 2), Eigen::MatrixXd::Zero(1, 2), 0.0});
  expectMessage(validateError(m), "hand", "uncertainty[0].dC", "expected 2x2");

  m = handBuilt();
  m.P0(1, 1) = -1.0;
  expectMessage(validateError(m), "hand", "P0", "not positive semidefinite");
}

// =============================================================================================
// loadModel (files)
// =============================================================================================

TEST(LoadModel, ReadsFileAndDefaultsNameToStem)
{
  TempDir dir;
  const std::string with_name = dir.write("zhou.yaml", kZhou);
  const ne::Model a = ne::loadModel(with_name);
  EXPECT_EQ(a.name, "zhou_example");
  EXPECT_EQ(a.n(), 2);
  EXPECT_EQ(a.A(0, 1), 0.0196);

  const std::string without_name = dir.write("plant_b.yaml", modelYaml({{"name", kRemove}}));
  EXPECT_EQ(ne::loadModel(without_name).name, "plant_b");

  // errors name the file path and the line
  const std::string bad = dir.write("bad.yaml", modelYaml({{"Q", "[[1, 0.5], [0.4, 1]]"}}));
  EXPECT_EQ(errorOf([&] { ne::loadModel(bad); }), bad + ":5: Q: not symmetric (Q(0,1) = 0.5 but Q(1,0) = 0.4)");
}

TEST(LoadModel, MissingFile)
{
  TempDir dir;
  const std::string path = (dir.path() / "nope.yaml").string();
  EXPECT_EQ(errorOf([&] { ne::loadModel(path); }), path + ": cannot open file");
  EXPECT_CONTAINS(errorOf([&] { ne::loadModel(dir.path().string()); }), "cannot open file");
}

TEST(LoadModel, YamlSyntaxError)
{
  TempDir dir;
  const std::string path = dir.write("syntax.yaml", "name: x\nA: [[1, 0], [0, 1]\nQ: [[1]]\n");
  const std::string msg = errorOf([&] { ne::loadModel(path); });
  EXPECT_EQ(msg.rfind(path + ":", 0), 0u) << msg;
  EXPECT_CONTAINS(msg, "YAML syntax error");
  // the line number follows the path
  const std::string rest = msg.substr(path.size() + 1);
  ASSERT_FALSE(rest.empty());
  EXPECT_TRUE(std::isdigit(static_cast<unsigned char>(rest[0]))) << msg;
}

TEST(LoadModel, TopLevelNotAMap)
{
  TempDir dir;
  const std::string path = dir.write("list.yaml", "- 1\n- 2\n");
  EXPECT_CONTAINS(errorOf([&] { ne::loadModel(path); }), "expected a map of keys at the top level");
  const std::string empty = dir.write("empty.yaml", "");
  EXPECT_EQ(errorOf([&] { ne::loadModel(empty); }), empty + ": empty document (expected a map of keys)");
}
