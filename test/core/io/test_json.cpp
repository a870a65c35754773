// The JSON writer and reader of the tools' files (io/json_writer.hpp, io/json_document.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <random>
#include <string>

#include "io/json_document.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/io/json_writer.hpp"

using namespace networked_estimation;

namespace
{

/// The message of the InputError that parsing `text` throws ("" when it parses).
std::string parseError(const std::string& text)
{
  try
  {
    JsonDocument doc(text, "f.json");
  }
  catch (const InputError& e)
  {
    return e.what();
  }
  return "";
}

std::string fieldError(const std::string& text, const std::function<void(const JsonField&)>& read)
{
  const JsonDocument doc(text, "f.json");
  try
  {
    read(JsonField(doc, doc.root(), ""));
  }
  catch (const InputError& e)
  {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(JsonWriter, LayoutSeparatorsAndOrder)
{
  JsonWriter w;
  w.beginObject();
  w.br(2).member("z", 1).br(2).key("list").beginArray().value(1.5).value(-2).endArray();
  w.br(2).key("rows").beginArray();
  w.br(4).beginObject().member("a", true).key("b").null().endObject();
  w.br(2).endArray();
  w.br(2).key("empty").beginArray().endArray();
  w.br(0).endObject();
  // members stay in the order written (not sorted), ", " and ": " between them, breaks where asked
  EXPECT_EQ(w.text(),
            "{\n  \"z\": 1,\n  \"list\": [1.5, -2],\n  \"rows\": [\n    {\"a\": true, \"b\": null}\n  ],\n"
            "  \"empty\": []\n}");
}

TEST(JsonWriter, NumbersAndStrings)
{
  auto one = [](double v) { return JsonWriter().value(v).text(); };
  EXPECT_EQ(one(2.0), "2");  // a whole number as an integer
  EXPECT_EQ(one(-3.0), "-3");
  EXPECT_EQ(one(0.1), "0.1");  // the shortest text that reads back to the same double
  EXPECT_EQ(one(1e-5), "1e-05");
  EXPECT_EQ(one(-0.0), "-0.0");  // keeps the sign
  EXPECT_EQ(one(std::nan("")), "null");
  EXPECT_EQ(one(std::numeric_limits<double>::infinity()), "null");
  EXPECT_EQ(JsonWriter().value(std::uint64_t(18446744073709551615ULL)).text(), "18446744073709551615");
  EXPECT_EQ(JsonWriter().value(std::string("a \"q\" \\ \n\t\x01")).text(), "\"a \\\"q\\\" \\\\ \\n\\t\\u0001\"");
  // bytes that are not UTF-8 become U+FFFD (JSON text is UTF-8)
  EXPECT_EQ(JsonWriter().value(std::string("x\xff")).text(), "\"x\xef\xbf\xbd\"");
}

TEST(JsonDocument, DoublesRoundTripBitForBit)
{
  // doubles of every magnitude, written and read back: the same bits
  std::mt19937_64 rng(7);
  std::vector<double> v = {
      0.0, -0.0, 1.0, 0.1, 1e-300, 5e-324, 1.7976931348623157e308, 9007199254740993.0, 85739067664200288.0};
  for (int i = 0; i < 2000; ++i)
  {
    std::uint64_t bits = rng();
    double d;
    std::memcpy(&d, &bits, sizeof d);
    if (std::isfinite(d))
      v.push_back(d);
  }
  JsonWriter w;
  w.beginObject().member("v", v).endObject();
  const JsonDocument doc(w.text(), "f.json");
  const std::vector<double> back = JsonField(doc, doc.root(), "")["v"].numbers();
  ASSERT_EQ(back.size(), v.size());
  for (std::size_t i = 0; i < v.size(); ++i)
    EXPECT_EQ(std::memcmp(&back[i], &v[i], sizeof(double)), 0) << i << ": " << v[i] << " read as " << back[i];
}

TEST(JsonDocument, SyntaxErrorsNameTheFileLineAndColumn)
{
  EXPECT_EQ(parseError("{\"a\": 1}"), "");
  EXPECT_EQ(parseError("[1]"), "f.json: line 1, column 1: expected '{', found '['");
  EXPECT_EQ(parseError(""), "f.json: line 1, column 1: expected '{', found the end of the file (truncated?)");
  const std::string bad = parseError("{\n  \"a\": 1,\n  \"b\": [1, 2,, 3]\n}");
  EXPECT_EQ(bad.rfind("f.json: line 3, column 14: syntax error", 0), 0u) << bad;
  const std::string cut = parseError("{\n  \"a\": [1, 2");
  EXPECT_EQ(cut.rfind("f.json: line 2, column 13: ", 0), 0u) << cut;
  EXPECT_NE(cut.find("truncated?"), std::string::npos) << cut;
  EXPECT_EQ(parseError("{\"a\": 1,\n \"a\": 2}"), "f.json: line 2: key 'a' given twice");
  EXPECT_EQ(parseError("{\"o\": [{\"k\": 1, \"k\": 1}]}"), "f.json: line 1: key 'k' given twice in 'o[0]'");
}

TEST(JsonDocument, FieldErrorsNameTheLineAndTheField)
{
  const std::string text = "{\n  \"n\": \"many\",\n  \"list\": [\n    {\"x\": [1, true]}\n  ],\n  \"u\": -1\n}";
  EXPECT_EQ(fieldError(text, [](const JsonField& f) { f["n"].integer(1, 10); }),
            "f.json: line 2: 'n': expected an integer in [1, 10], found \"many\"");
  EXPECT_EQ(fieldError(text, [](const JsonField& f) { f["list"].elements()[0]["x"].numbers(); }),
            "f.json: line 4: 'list[0].x[1]': expected a number or \"nan\", \"-nan\", \"inf\", \"-inf\", found true");
  EXPECT_EQ(fieldError(text, [](const JsonField& f) { f["u"].uint64(); }),
            "f.json: line 6: 'u': expected a non-negative integer, found -1");
  EXPECT_EQ(fieldError(text, [](const JsonField& f) { f.keys({"n", "list"}); }), "f.json: line 6: 'u': unknown key");
  EXPECT_EQ(fieldError(text,
                       [](const JsonField& f) {
                         f.keys({"n", "list", "u", "w"});
                       }),
            "f.json: line 1: missing key 'w'");
  EXPECT_EQ(fieldError("{\"a\": 11}", [](const JsonField& f) { f["a"].integer(1, 10); }),
            "f.json: line 1: 'a': expected an integer in [1, 10], found 11");
  EXPECT_EQ(fieldError("{\"a\": 0}", [](const JsonField& f) { f["a"].integer(1, 10); }),
            "f.json: line 1: 'a': expected an integer in [1, 10], found 0");
  // the strings of the values JSON has no number for
  const JsonDocument doc("{\"v\": [\"nan\", \"-inf\"]}", "f.json");
  const JsonField v = JsonField(doc, doc.root(), "")["v"];
  EXPECT_TRUE(std::isnan(v.elements()[0].number()));
  EXPECT_EQ(v.elements()[1].number(), -std::numeric_limits<double>::infinity());
  // a number beyond the doubles is refused where it stands
  EXPECT_EQ(parseError("{\"v\": [1,\n 1e400]}"), "f.json: line 2, column 7: number overflow parsing '1e400'");
}
