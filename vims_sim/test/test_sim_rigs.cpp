// Rig files (config/rigs/*.yaml, vims_sim --rig), the image size and the camera's mounting.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "sim_options_test_support.h"
#include "vims_sim/rig_file.h"
#include "vims_sim/sim_options.h"
#include "vims_sim/sim_setup.h"

using namespace vims::sim;
namespace fs = std::filesystem;

namespace {

constexpr double kDeg = M_PI / 180.0;

const std::vector<std::string> kBase = {"--scenario", "tank", "--duration", "20", "--seed", "3", "--out", "/tmp/rig"};

std::vector<std::string> withBase(const std::vector<std::string>& extra) {
  std::vector<std::string> args = kBase;
  args.insert(args.end(), extra.begin(), extra.end());
  return args;
}

std::string rigPath(const std::string& name) { return std::string(VIMS_SOURCE_DIR) + "/config/rigs/" + name + ".yaml"; }

/// A rig file with `text` in a temporary folder.
fs::path writtenRig(const std::string& text) {
  const fs::path path =
      fs::temp_directory_path() / ("rig_" + std::to_string(::getpid()) + "_" +
                                   ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".yaml");
  std::ofstream(path) << text;
  return path;
}

Eigen::Matrix3d nominalCameraRotation() {
  Eigen::Matrix3d R;
  R << 0, -1, 0, -1, 0, 0, 0, 0, -1;
  return R;
}

}  // namespace

TEST(RigFile, EveryRigFileParsesAndTheDefaultOneIsTheDefaultRig) {
  int files = 0;
  for (const auto& entry : fs::directory_iterator(std::string(VIMS_SOURCE_DIR) + "/config/rigs")) {
    SCOPED_TRACE(entry.path().string());
    const auto options = parseSimCommandLine(withBase({"--rig", entry.path().string()}));
    ASSERT_TRUE(options.has_value());
    EXPECT_NO_THROW(buildSimSetup(*options));
    ++files;
  }
  EXPECT_GE(files, 4);

  const SimSetup plain = buildSimSetup(*parseSimCommandLine(kBase));
  const SimSetup with_default = buildSimSetup(*parseSimCommandLine(withBase({"--rig", rigPath("default")})));
  EXPECT_EQ(with_default.config.toYaml(), plain.config.toYaml());
}

TEST(RigFile, ItsFlagsAreTheCommandLinesAndTheCommandLineOverridesThem) {
  const auto rig = parseSimCommandLine(withBase({"--rig", rigPath("tilted_hd")}));
  ASSERT_TRUE(rig.has_value());
  EXPECT_EQ(rig->image_width, 1024);
  EXPECT_EQ(rig->image_height, 768);
  EXPECT_EQ(rig->camera_tilt_deg, 30.0);
  EXPECT_EQ(rig->rates.camera, 15.0);
  EXPECT_EQ(rig->rates.imu, 400.0);
  // A flag before or after --rig overrides the file.
  const auto before = parseSimCommandLine(withBase({"--camera-tilt-deg", "10", "--rig", rigPath("tilted_hd")}));
  const auto after = parseSimCommandLine(withBase({"--rig", rigPath("tilted_hd"), "--imu-rate-hz", "200"}));
  EXPECT_EQ(before->camera_tilt_deg, 10.0);
  EXPECT_EQ(before->image_width, 1024);
  EXPECT_EQ(after->rates.imu, 200.0);
  EXPECT_EQ(after->camera_tilt_deg, 30.0);
}

TEST(RigFile, ErrorsNameTheFileAndTheKey) {
  const fs::path unknown = writtenRig("image-width: 800\nterrain: rough\n");
  std::string e = test::commandLineError(withBase({"--rig", unknown.string()}));
  EXPECT_NE(e.find("--rig " + unknown.string()), std::string::npos) << e;
  EXPECT_NE(e.find("'terrain' is not a rig flag"), std::string::npos) << e;

  const fs::path out_of_range = writtenRig("camera-tilt-deg: 60\n");
  e = test::commandLineError(withBase({"--rig", out_of_range.string()}));
  EXPECT_NE(e.find("--rig " + out_of_range.string() + ": --camera-tilt-deg: must be in [-45, 45]"), std::string::npos)
      << e;

  const fs::path not_a_number = writtenRig("image-width: wide\n");
  e = test::commandLineError(withBase({"--rig", not_a_number.string()}));
  EXPECT_NE(e.find(": --image-width: expected a number, got 'wide'"), std::string::npos) << e;

  const fs::path fractional = writtenRig("image-height: 480.5\n");
  EXPECT_NE(
      test::commandLineError(withBase({"--rig", fractional.string()})).find("--image-height: expected an integer"),
      std::string::npos);
  const fs::path nested = writtenRig("image-width: [640, 480]\n");
  EXPECT_NE(test::commandLineError(withBase({"--rig", nested.string()})).find("image-width: expected a single value"),
            std::string::npos);
  const fs::path list = writtenRig("- image-width\n");
  EXPECT_NE(test::commandLineError(withBase({"--rig", list.string()})).find("expected a mapping"), std::string::npos);
  EXPECT_NE(test::commandLineError(withBase({"--rig", "/nonexistent/rig.yaml"})).find("cannot read the file"),
            std::string::npos);
  EXPECT_NE(test::commandLineError(withBase({"--rig", rigPath("default"), "--rig", rigPath("fisheye")}))
                .find("--rig: given twice"),
            std::string::npos);
  EXPECT_NE(test::commandLineError(withBase({"--rig"})).find("--rig: missing value"), std::string::npos);
  // The same checks on the command line name the flag alone.
  EXPECT_NE(test::commandLineError(withBase({"--image-width", "100"})).find("--image-width: must be in [160, 2048]"),
            std::string::npos);
  EXPECT_NE(test::commandLineError(withBase({"--camera-roll-deg", "200"})).find("--camera-roll-deg"),
            std::string::npos);
  for (const fs::path& p : {unknown, out_of_range, not_a_number, fractional, nested, list}) fs::remove(p);
}

TEST(SimSetup, TheFocalLengthScalesWithTheImageWidth) {
  const SimSetup plain = buildSimSetup(*parseSimCommandLine(kBase));
  const SimSetup large =
      buildSimSetup(*parseSimCommandLine(withBase({"--image-width", "1280", "--image-height", "720"})));
  EXPECT_EQ(large.config.camera.width, 1280);
  EXPECT_EQ(large.config.camera.height, 720);
  EXPECT_NEAR(large.config.camera.fx, 2.0 * plain.config.camera.fx, 1e-9);
  EXPECT_NEAR(large.config.camera.fy, 2.0 * plain.config.camera.fy, 1e-9);
  // The principal point's offset from the centre doubles too.
  EXPECT_NEAR(large.config.camera.cx - 639.5, 2.0 * (plain.config.camera.cx - 319.5), 1e-9);
  EXPECT_NEAR(large.config.camera.cy - 359.5, 2.0 * (plain.config.camera.cy - 239.5), 1e-9);
  EXPECT_TRUE(large.config.camera.T_b_c.isApprox(plain.config.camera.T_b_c, 0.0));
}

TEST(SimSetup, TheCameraIsTiltedTowardsTheBowAndTurnedAboutItsOpticalAxis) {
  const SimSetup plain = buildSimSetup(*parseSimCommandLine(kBase));
  const Eigen::Matrix3d R_plain = plain.config.camera.T_b_c.linear();

  // Tilt: the whole camera turns about the body's y axis, its optical axis towards +x_b.
  const SimSetup tilted = buildSimSetup(*parseSimCommandLine(withBase({"--camera-tilt-deg", "30"})));
  const Eigen::Matrix3d R_tilted = tilted.config.camera.T_b_c.linear();
  EXPECT_TRUE(R_tilted.isApprox(Eigen::AngleAxisd(-30.0 * kDeg, Eigen::Vector3d::UnitY()) * R_plain, 1e-12));
  const Eigen::Vector3d axis = R_tilted.col(2);
  EXPECT_NEAR(std::acos(-axis.z()) / kDeg, 30.0, 3.5);  // within the rig's 2 deg mounting jitter
  EXPECT_GT(axis.x(), std::sin(26.0 * kDeg));

  // Roll about the optical axis: R = R_nominal Rz(roll) S where the untilted rig is R_nominal S.
  const SimSetup rolled = buildSimSetup(*parseSimCommandLine(withBase({"--camera-roll-deg", "90"})));
  const Eigen::Matrix3d R_nominal = nominalCameraRotation();
  const Eigen::Matrix3d roll =
      R_nominal.transpose() * rolled.config.camera.T_b_c.linear() * R_plain.transpose() * R_nominal;
  EXPECT_TRUE(roll.isApprox(Eigen::AngleAxisd(90.0 * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix(), 1e-12));
  // Turned by 90 deg, the image's x axis (starboard before) points to the stern, its up
  // (-y_c, the bow before) to starboard: y_c is +y_b.
  EXPECT_LT(rolled.config.camera.T_b_c.linear().col(0).x(), -std::cos(3.5 * kDeg));
  EXPECT_GT(rolled.config.camera.T_b_c.linear().col(1).y(), std::cos(3.5 * kDeg));
  // Nothing else of the rig moves.
  EXPECT_TRUE(rolled.config.sonar.T_b_s.isApprox(plain.config.sonar.T_b_s, 0.0));
  EXPECT_EQ(rolled.config.camera.fx, plain.config.camera.fx);
}
