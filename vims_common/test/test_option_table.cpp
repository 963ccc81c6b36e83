#include <gtest/gtest.h>

#include <cmath>

#include "vims_common/option_table.h"

namespace {

using vims::Bounds;
using vims::ConfigError;
using vims::ConfigReader;
using vims::OptionTable;

enum class Shape { kFlat, kSloped };
std::string shapeName(Shape shape) { return shape == Shape::kFlat ? "flat" : "sloped"; }

struct Inner {
  double sigma = 0.5;
};

struct Example {
  int count = 4;
  double gain = 0.1;
  double angle_rad = 2.0 * M_PI / 180.0;
  bool enabled = true;
  std::string path = "maps/a \"b\".bin";
  Shape shape = Shape::kFlat;
  uint64_t seed = 1ULL << 40;
  Inner inner;
};

const OptionTable<Inner>& innerTable() {
  static const auto table = OptionTable<Inner>().number("sigma", &Inner::sigma, Bounds::positive());
  return table;
}

const OptionTable<Example>& exampleTable() {
  static const auto table = OptionTable<Example>()
                                .integer("count", &Example::count, Bounds::closed(1, 10))
                                .number("gain", &Example::gain, Bounds::nonNegative())
                                .scaledNumber("angle_deg", &Example::angle_rad, M_PI / 180.0, Bounds::closed(0.0, 90.0))
                                .flag("enabled", &Example::enabled)
                                .integer<uint64_t>("seed", &Example::seed, Bounds::nonNegative())
                                .text("path", &Example::path, false)
                                .choice<Shape>("shape", &Example::shape, {Shape::kFlat, Shape::kSloped}, shapeName)
                                .section<Inner>("inner", &Example::inner, innerTable())
                                .rule([](const Example& e) -> std::optional<vims::OptionViolation> {
                                  if (e.gain > e.count) return vims::OptionViolation{"gain", "must be <= count"};
                                  return std::nullopt;
                                });
  return table;
}

Example readExample(const std::string& yaml) {
  Example e;
  exampleTable().read(ConfigReader::fromString(yaml, "ex.yaml"), &e);
  return e;
}

std::string errorOf(const std::string& yaml) {
  try {
    readExample(yaml);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(OptionTable, AbsentKeysKeepTheDefaultsAndPresentOnesAreRead) {
  const Example e = readExample("count: 7\nangle_deg: 30\nshape: sloped\ninner: {sigma: 2.5}\nenabled: false\n");
  EXPECT_EQ(e.count, 7);
  EXPECT_DOUBLE_EQ(e.gain, 0.1);
  EXPECT_NEAR(e.angle_rad, M_PI / 6.0, 1e-15);
  EXPECT_EQ(e.shape, Shape::kSloped);
  EXPECT_DOUBLE_EQ(e.inner.sigma, 2.5);
  EXPECT_FALSE(e.enabled);
}

TEST(OptionTable, ErrorsNameTheKey) {
  EXPECT_NE(errorOf("cuont: 3\n").find("ex.yaml: cuont: unknown key (known keys here: angle_deg, count"),
            std::string::npos);
  EXPECT_NE(errorOf("count: 11\n").find("count: must be in [1, 10], got 11"), std::string::npos);
  EXPECT_NE(errorOf("count: many\n").find("count: value"), std::string::npos);
  EXPECT_NE(errorOf("gain: -0.5\n").find("gain: must be >= 0, got -0.5"), std::string::npos);
  EXPECT_NE(errorOf("gain: .nan\n").find("gain: must be >= 0"), std::string::npos);
  EXPECT_NE(errorOf("angle_deg: 91\n").find("angle_deg: must be in [0, 90], got 91"), std::string::npos);
  EXPECT_NE(errorOf("path: \"\"\n").find("path: must not be empty"), std::string::npos);
  EXPECT_NE(errorOf("shape: round\n").find("shape: must be one of flat, sloped; got 'round'"), std::string::npos);
  EXPECT_NE(errorOf("inner: {sigma: 0}\n").find("inner.sigma: must be > 0, got 0"), std::string::npos);
  EXPECT_NE(errorOf("inner: {sgima: 1}\n").find("inner.sgima: unknown key"), std::string::npos);
  EXPECT_NE(errorOf("inner: 3\n").find("inner: expected a mapping"), std::string::npos);
  EXPECT_NE(errorOf("count: 2\ngain: 3\n").find("gain: must be <= count"), std::string::npos);
}

TEST(OptionTable, ToYamlReadsBackToTheSameOptions) {
  Example e;
  e.gain = 0.1 + 0.2;  // not a short decimal: the text must still be exact
  e.angle_rad = 2.0 * M_PI / 180.0;
  const std::string yaml = exampleTable().toYaml(e);
  EXPECT_NE(yaml.find("angle_deg: 2\n"), std::string::npos) << yaml;  // the file's unit, rounding hidden
  EXPECT_NE(yaml.find("inner:\n  sigma: 0.5\n"), std::string::npos) << yaml;
  const Example back = readExample(yaml);
  EXPECT_EQ(back.gain, e.gain);
  EXPECT_EQ(back.path, e.path);
  EXPECT_EQ(back.seed, e.seed);
  EXPECT_EQ(exampleTable().toYaml(back), yaml);
}

TEST(OptionTable, FirstViolationChecksOptionsBuiltInCode) {
  Example e;
  EXPECT_FALSE(exampleTable().firstViolation(e).has_value());
  e.gain = 5.0;
  EXPECT_EQ(exampleTable().firstViolation(e)->key, "gain");  // the rule
  e.gain = 0.0;
  e.inner.sigma = -1.0;
  const auto v = exampleTable().firstViolation(e);
  ASSERT_TRUE(v.has_value());
  EXPECT_EQ(v->key, "inner");
  EXPECT_NE(v->message.find("sigma: must be > 0"), std::string::npos);
}

TEST(OptionTable, WithoutDropsAKey) {
  const auto table = exampleTable().without("shape");
  Example e;
  EXPECT_THROW(table.read(ConfigReader::fromString("shape: flat\n"), &e), ConfigError);
  EXPECT_EQ(table.toYaml(e).find("shape"), std::string::npos);
}

TEST(OptionTable, RowsListEveryKeyWithItsAllowedValues) {
  const std::vector<vims::OptionRow> rows = exampleTable().rows();
  ASSERT_EQ(rows.size(), 8u);
  EXPECT_EQ(rows[0].key, "count");
  EXPECT_EQ(rows[0].allowed, "whole number [1, 10]");
  EXPECT_EQ(rows[1].allowed, ">= 0");
  EXPECT_EQ(rows[6].allowed, "flat, sloped");
  EXPECT_EQ(rows[7].key, "inner.sigma");
  EXPECT_EQ(rows[7].allowed, "> 0");
}

TEST(OptionTable, NumbersPrintShortestExact) {
  EXPECT_EQ(vims::formatOptionNumber(0.1), "0.1");
  EXPECT_EQ(vims::formatOptionNumber(2.0), "2");
  EXPECT_EQ(vims::formatOptionNumber(1e-5), "1e-05");
  EXPECT_EQ(std::stod(vims::formatOptionNumber(0.1 + 0.2)), 0.1 + 0.2);
}

}  // namespace
