// Tests of the checked-field reader and its key tables (config/field.hpp).
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

#include "config/field.hpp"
#include "networked_estimation/common/error.hpp"

namespace ne = networked_estimation;
using ne::detail::Field;
using ne::detail::KeyRule;
using ne::detail::optionalKey;
using ne::detail::readKeys;
using ne::detail::requiredKey;

namespace
{

template <typename F>
std::string errorOf(F&& f)
{
  try
  {
    f();
  }
  catch (const ne::ConfigError& e)
  {
    return e.what();
  }
  return "(no error)";
}

/// What a table read: the rows in the order they ran.
struct Trace
{
  std::vector<std::string> ran;
  double gain = 0.0;
};

const std::vector<KeyRule<Trace>>& table()
{
  static const std::vector<KeyRule<Trace>> rows = {
      requiredKey<Trace>(
          "gain",
          [](const Field& f, Trace& t)
          {
            t.ran.push_back("gain");
            t.gain = f.number();
          },
          "the loop needs a gain"),
      optionalKey<Trace>(
          "mode", [](const Field& f, Trace& t) { t.ran.push_back("mode=" + f.string()); },
          [](const Field&, Trace& t) { t.ran.push_back("mode absent"); }),
      optionalKey<Trace>("limit",
                         [](const Field& f, Trace& t)
                         {
                           t.ran.push_back("limit");
                           if (f.number() < t.gain)  // a row sees what earlier rows read
                             f.fail("expected at least gain = " + std::to_string(static_cast<int>(t.gain)));
                         }),
  };
  return rows;
}

std::string tableError(const std::string& yaml, Trace* trace = nullptr)
{
  Trace local;
  return errorOf([&] { readKeys(Field(YAML::Load(yaml), "t.yaml"), table(), trace ? *trace : local); });
}

}  // namespace

// The rows run in the table's order, an absent optional key runs its absence rule, and a row uses
// what an earlier row read.
TEST(KeyTable, RowsRunInOrderWithTheirAbsenceRules)
{
  Trace t;
  readKeys(Field(YAML::Load("limit: 5\ngain: 2"), "t.yaml"), table(), t);
  EXPECT_EQ(t.ran, (std::vector<std::string>{"gain", "mode absent", "limit"}));
  EXPECT_EQ(t.gain, 2.0);
  EXPECT_EQ(tableError("gain: 3\nlimit: 1"), "t.yaml:2: limit: expected at least gain = 3");
}

// A key no row reads is refused before any row runs (a typo is named as a typo, not as the
// missing key it was meant to be), with the table's keys as the known ones.
TEST(KeyTable, UnknownKeysAreTheOnesNoRowReads)
{
  Trace t;
  EXPECT_EQ(tableError("gian: 2\nmode: fast", &t), "t.yaml:1: gian: unknown key (known keys: gain, mode, limit)");
  EXPECT_TRUE(t.ran.empty());
  EXPECT_EQ(tableError("gain: 2\ngain: 3"), "t.yaml:2: gain: duplicate key");
  EXPECT_EQ(tableError("gain: 2\n[a]: 3"), "t.yaml:2: keys must be plain names, found a list");
  EXPECT_EQ(tableError("mode: fast"), "t.yaml:1: gain: missing required key (the loop needs a gain)");
  EXPECT_EQ(tableError("[1, 2]"), "t.yaml:1: expected a map, found a list");
}

// A field builds its own key path and line: "<source>:<line>: <key>: <problem>".
TEST(Field, KeyPathsAndLines)
{
  const Field root(YAML::Load("sensors:\n  - name: a\n    R: [[1, 0], [0, -1]]\n  - name: b\n"), "m.yaml");
  const Field r = root["sensors"][0]["R"];
  EXPECT_EQ(r.key(), "sensors[0].R");
  EXPECT_EQ(r.line(), 3);
  EXPECT_EQ(errorOf([&] { r.checkCovariance(r.matrix(2, 2, ""), "R", ne::Definiteness::POSITIVE); })
                .rfind("m.yaml:3: sensors[0].R: ", 0),
            0u);
  EXPECT_EQ(errorOf([&] { root["sensors"][1].required("C", "give C"); }),
            "m.yaml:4: sensors[1].C: missing required key (give C)");
  EXPECT_EQ(errorOf([&] { root["sensors"][0]["name"].integer(1); }),
            "m.yaml:2: sensors[0].name: expected an integer >= 1, found 'a'");
  EXPECT_FALSE(root["sensors"][2].present());
  EXPECT_FALSE(root["nothing"]["deeper"].present());
  EXPECT_EQ(root["sensors"].elements().size(), 2u);
}

// Parameters have no lines: the message has none and shows a value of the wrong kind as it is.
TEST(Field, ParametersShowTheValueWithoutALine)
{
  const YAML::Node doc = YAML::Load("topic: [a, b]\nrate: fast");
  EXPECT_EQ(errorOf([&] { Field(doc, "/est parameters", Field::Origin::PARAMETERS)["topic"].string(); }),
            "/est parameters: topic: expected a string, found '[a, b]'");
  EXPECT_EQ(errorOf([&] { Field(doc, "/est parameters", Field::Origin::PARAMETERS)["rate"].number(); }),
            "/est parameters: rate: expected a number, found 'fast'");
  EXPECT_EQ(errorOf([&] { Field(doc, "f.yaml")["topic"].string(); }),
            "f.yaml:1: topic: expected a string, found a list");
}

// One grammar: the booleans and integers every reader takes.
TEST(Field, OneGrammarForBooleansAndIntegers)
{
  const YAML::Node doc = YAML::Load("a: True\nb: yes\nc: '+7'\nd: 0x10\ne: -3");
  const Field f(doc, "g.yaml");
  EXPECT_TRUE(f["a"].boolean());
  EXPECT_EQ(errorOf([&] { f["b"].boolean(); }), "g.yaml:2: b: expected true or false, found 'yes'");
  EXPECT_EQ(f["c"].integer(0), 7u);
  EXPECT_EQ(errorOf([&] { f["d"].integer(0); }), "g.yaml:4: d: expected a non-negative integer, found '0x10'");
  EXPECT_EQ(errorOf([&] { f["e"].integer(0); }), "g.yaml:5: e: expected a non-negative integer, found -3");
}
