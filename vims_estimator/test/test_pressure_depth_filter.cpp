// The pressure front end of the VIO: depth conversion, spikes, bad values; and the seabed and
// pressure options.
#include <gtest/gtest.h>

#include <cmath>

#include "vims_estimator/estimator_options.h"
#include "vims_estimator/pressure_depth_filter.h"

namespace vims {
namespace {

PressureCalibration calibration() {
  PressureCalibration c;
  c.atmospheric_pa = 101325.0;
  c.water_density = 1025.0;
  c.rate_hz = 10.0;
  return c;
}

double pressureAt(double depth) { return 101325.0 + 1025.0 * 9.81 * depth; }

TEST(PressureDepthFilter, ConvertsAndDropsSpikesAndBadValues) {
  PressureDepthFilter filter(calibration(), 9.81, PressureOptions{});
  int accepted = 0;
  for (int k = 0; k < 30; ++k) {
    const double depth = 12.0 + 0.01 * k;  // descending at 0.1 m/s
    double p = pressureAt(depth);
    if (k == 15) p += 2.0e4;  // a 2 m spike
    const auto r = filter.add({0.1 * k, p});
    if (k == 15) {
      EXPECT_FALSE(r.accepted);
      EXPECT_NE(r.rejected_because.find("spike"), std::string::npos) << r.rejected_because;
    } else {
      EXPECT_TRUE(r.accepted) << k << ": " << r.rejected_because;
      EXPECT_NEAR(r.depth, depth, 1e-9);
      ++accepted;
    }
  }
  EXPECT_EQ(accepted, 29);
  EXPECT_FALSE(filter.add({3.0, std::nan("")}).accepted);
  EXPECT_FALSE(filter.add({3.1, -5.0}).accepted);
  // The clock going backwards (a bag restarted) starts a new window: a depth far from the old
  // median is accepted.
  const auto restarted = filter.add({0.0, pressureAt(20.0)});
  EXPECT_TRUE(restarted.accepted) << restarted.rejected_because;
}

TEST(PressureDepthFilter, FollowsARealDepthStepAfterHalfAWindow) {
  PressureDepthFilter filter(calibration(), 9.81, PressureOptions{});
  for (int k = 0; k < 10; ++k) filter.add({0.1 * k, pressureAt(5.0)});
  // The vehicle is 1 m deeper from t = 1 s on (e.g. after a gap in the data): the first samples
  // look like spikes, then the median moves and the new depth is accepted.
  int first_accepted = -1;
  for (int k = 10; k < 30; ++k) {
    if (filter.add({0.1 * k, pressureAt(6.0)}).accepted && first_accepted < 0) first_accepted = k;
  }
  EXPECT_GE(first_accepted, 11);
  EXPECT_LE(first_accepted, 16);  // half of the 1 s window at 10 Hz, plus one
}

TEST(SeabedOptions, ParseValidateAndPrint) {
  EXPECT_EQ(EstimatorOptions{}.seabed.model, SeabedModel::kLocalPlane);
  const auto o = EstimatorOptions::fromReader(ConfigReader::fromString(
      "seabed: {model: horizontal, slope_random_walk: 0.05}\npressure: {enabled: false, spike_threshold_m: 0.5}\n"));
  EXPECT_EQ(o.seabed.model, SeabedModel::kHorizontal);
  EXPECT_DOUBLE_EQ(o.seabed.slope_random_walk, 0.05);
  EXPECT_FALSE(o.pressure.enabled);
  EXPECT_DOUBLE_EQ(o.pressure.spike_threshold_m, 0.5);
  const auto back = EstimatorOptions::fromReader(ConfigReader::fromString(o.toYaml()));
  EXPECT_EQ(back.seabed.model, SeabedModel::kHorizontal);
  EXPECT_FALSE(back.pressure.enabled);
  auto error = [](const std::string& yaml) {
    try {
      EstimatorOptions::fromReader(ConfigReader::fromString(yaml));
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error("seabed: {model: sloped}").find("seabed.model"), std::string::npos);
  EXPECT_NE(error("seabed: {max_slope: 2.0}").find("seabed.max_slope"), std::string::npos);
  EXPECT_NE(error("pressure: {median_window_s: 0}").find("pressure.median_window_s"), std::string::npos);
  EXPECT_NE(error("pressure: {enable: true}").find("enable"), std::string::npos);
}

}  // namespace
}  // namespace vims
