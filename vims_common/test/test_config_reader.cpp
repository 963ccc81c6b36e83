#include <gtest/gtest.h>

#include "vims_common/config_reader.h"

using vims::ConfigError;
using vims::ConfigReader;

namespace {
std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(ConfigReader, ReadsScalarsVectorsAndDefaults) {
  const auto r = ConfigReader::fromString("a: 3\nb: {c: 2.5, v: [1, 2, 3]}\n");
  EXPECT_EQ(r.get<int>("a"), 3);
  EXPECT_DOUBLE_EQ(r.child("b").get<double>("c"), 2.5);
  EXPECT_EQ(r.child("b").getVector("v", 3).size(), 3u);
  EXPECT_DOUBLE_EQ(r.get<double>("missing", 7.0), 7.0);
}

TEST(ConfigReader, ErrorsNameTheFullKeyPath) {
  const auto r = ConfigReader::fromString("sec: {x: abc, v: [1, 2]}\n", "cfg.yaml");
  EXPECT_NE(errorOf([&] { r.child("sec").get<double>("x"); }).find("cfg.yaml: sec.x"), std::string::npos);
  EXPECT_NE(errorOf([&] { r.child("sec").getVector("v", 3); }).find("sec.v: expected 3 numbers, got 2"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { r.child("sec").get<int>("nope"); }).find("sec.nope: required key is missing"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { r.child("other"); }).find("other: required section is missing"), std::string::npos);
}

TEST(ConfigReader, RejectsUnknownKeysByName) {
  const auto r = ConfigReader::fromString("window_size: 10\nwindw_size: 3\n");
  const std::string msg = errorOf([&] { r.rejectUnknownKeys({"window_size"}); });
  EXPECT_NE(msg.find("windw_size: unknown key"), std::string::npos) << msg;
  EXPECT_NO_THROW(r.rejectUnknownKeys({"window_size", "windw_size"}));
}

TEST(ConfigReader, TransformChecksRotationAndLastRow) {
  const auto ok = ConfigReader::fromString("T: [0,-1,0,1, 1,0,0,2, 0,0,1,3, 0,0,0,1]\n");
  const Eigen::Isometry3d T = ok.getTransform("T");
  EXPECT_NEAR((T * Eigen::Vector3d(1, 0, 0) - Eigen::Vector3d(1, 3, 3)).norm(), 0.0, 1e-12);
  const auto bad_rot = ConfigReader::fromString("T: [2,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]\n");
  EXPECT_NE(errorOf([&] { bad_rot.getTransform("T"); }).find("not a proper rotation"), std::string::npos);
  const auto bad_row = ConfigReader::fromString("T: [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,1,1]\n");
  EXPECT_NE(errorOf([&] { bad_row.getTransform("T"); }).find("last row"), std::string::npos);
  const auto reflection = ConfigReader::fromString("T: [-1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]\n");
  EXPECT_FALSE(errorOf([&] { reflection.getTransform("T"); }).empty());
}

TEST(ConfigReader, RangeChecks) {
  const auto r = ConfigReader::fromString("x: -1\n");
  EXPECT_NE(errorOf([&] { vims::requirePositive(r, "x", -1.0); }).find("x: must be > 0"), std::string::npos);
  EXPECT_THROW(vims::requireInRange(r, "x", 5.0, 0.0, 1.0), ConfigError);
  EXPECT_NO_THROW(vims::requireNonNegative(r, "x", 0.0));
}

TEST(ConfigReader, UnreadableFileIsAConfigError) {
  EXPECT_THROW(ConfigReader::fromFile("/nonexistent/vims.yaml"), ConfigError);
  EXPECT_THROW(ConfigReader::fromString("[1, 2]"), ConfigError);
}
