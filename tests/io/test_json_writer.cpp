#include "lsdem/io/JsonWriter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <sstream>

using lsdem::io::JsonWriter;

TEST(JsonWriter, CompactNestedDocument) {
  std::ostringstream s;
  JsonWriter w(s, 0);
  w.beginObject()
      .field("dimension", 3)
      .field("volume", 0.5)
      .field("name", "a \"quoted\"\nline")
      .field("ok", true)
      .key("centroid")
      .value(Eigen::Vector3d(1.0, -2.5, 0.1))
      .key("empty")
      .beginArray()
      .endArray()
      .key("list")
      .beginArray()
      .beginObject()
      .field("n", 1)
      .endObject()
      .value(2)
      .endArray()
      .endObject();
  EXPECT_EQ(s.str(),
            R"({"dimension":3,"volume":0.5,"name":"a \"quoted\"\nline","ok":true,"centroid":[1,-2.5,0.1],)"
            R"("empty":[],"list":[{"n":1},2]})");
}

TEST(JsonWriter, NumbersRoundTripAndNonFiniteIsNull) {
  std::ostringstream s;
  JsonWriter w(s, 0);
  const double third = 1.0 / 3.0;
  w.beginArray().value(third).value(std::numeric_limits<double>::quiet_NaN()).value(-INFINITY).value(1e-300).endArray();
  EXPECT_EQ(s.str(), "[0.3333333333333333,null,null,1e-300]");
  EXPECT_EQ(std::stod("0.3333333333333333"), third);
}

TEST(JsonWriter, IndentedOutput) {
  std::ostringstream s;
  JsonWriter w(s, 2);
  w.beginObject().field("a", 1).key("b").beginArray().value(2).endArray().endObject();
  EXPECT_EQ(s.str(), "{\n  \"a\": 1,\n  \"b\": [\n    2\n  ]\n}\n");
}

TEST(JsonWriter, MisuseIsALogicError) {
  std::ostringstream s;
  JsonWriter w(s, 0);
  w.beginObject();
  EXPECT_THROW(w.value(1), std::logic_error);
}
