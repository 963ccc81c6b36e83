// The seabed terrain: exact zero when flat, every term's gradient against central differences,
// the terms' sizes, determinism, ray intersections (first crossing, sloped plane, rocks), the
// sonar on terrain and the pressure sensor.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>

#include "vims_common/sequence_config.h"
#include "vims_sim/random.h"
#include "vims_sim/sensor_models.h"
#include "vims_sim/terrain.h"

using namespace vims::sim;

namespace {

constexpr double kDeg = M_PI / 180.0;

TerrainParams only(double slope, double relief, double roughness, double rock_height, double rock_density) {
  TerrainParams p;
  p.slope_deg = slope;
  p.slope_azimuth_deg = 57.0;
  p.relief_m = relief;
  p.relief_wavelength_m = 25.0;
  p.roughness_m = roughness;
  p.rock_height_m = rock_height;
  p.rock_density = rock_density;
  p.seed = 4242;
  return p;
}

TerrainParams roughTerrain() { return only(2.0, 0.25, 0.1, 0.3, 0.05); }

/// Points inside rocks (the dome is where the rock term's gradient is interesting).
std::vector<Eigen::Vector2d> pointsOnRocks(const SeabedTerrain& terrain, int wanted) {
  std::vector<Eigen::Vector2d> points;
  Rng rng(7);
  for (int64_t i = -20; i < 20 && static_cast<int>(points.size()) < wanted; ++i) {
    for (int64_t j = -20; j < 20 && static_cast<int>(points.size()) < wanted; ++j) {
      const auto rock = terrain.rockInCell(i, j);
      if (!rock) continue;
      const double angle = rng.uniform(0.0, 2.0 * M_PI), r = rock->radius * std::sqrt(rng.uniform(0.0, 0.98));
      points.push_back(rock->centre + r * Eigen::Vector2d(std::cos(angle), std::sin(angle)));
    }
  }
  return points;
}

double worstGradientError(const SeabedTerrain& terrain, const std::vector<Eigen::Vector2d>& points, bool large_scale) {
  const double h = 1e-5;
  double worst = 0.0;
  for (const Eigen::Vector2d& p : points) {
    Eigen::Vector2d gradient;
    auto height = [&](double x, double y) { return large_scale ? terrain.largeScale(x, y) : terrain.height(x, y); };
    if (large_scale) {
      terrain.largeScale(p.x(), p.y(), &gradient);
    } else {
      terrain.height(p.x(), p.y(), &gradient);
    }
    const Eigen::Vector2d numeric((height(p.x() + h, p.y()) - height(p.x() - h, p.y())) / (2 * h),
                                  (height(p.x(), p.y() + h) - height(p.x(), p.y() - h)) / (2 * h));
    worst = std::max(worst, (gradient - numeric).norm());
  }
  return worst;
}

std::vector<Eigen::Vector2d> randomPoints(int n, double half_size, uint64_t seed) {
  Rng rng(seed);
  std::vector<Eigen::Vector2d> points;
  for (int i = 0; i < n; ++i) {
    points.emplace_back(rng.uniform(-half_size, half_size), rng.uniform(-half_size, half_size));
  }
  return points;
}

}  // namespace

TEST(Terrain, FlatIsExactlyZero) {
  TerrainParams seeded;
  seeded.seed = 99;
  seeded.slope_azimuth_deg = 123.0;  // a direction without a slope
  seeded.rock_height_m = 0.3;        // rocks of zero density
  for (const SeabedTerrain& terrain : {SeabedTerrain(), SeabedTerrain(seeded)}) {
    ASSERT_TRUE(terrain.isFlat());
    EXPECT_TRUE(terrain.reliefWaves().empty());
    EXPECT_TRUE(terrain.roughnessWaves().empty());
    EXPECT_EQ(terrain.slopeBound(), 0.0);
    for (const Eigen::Vector2d& p : randomPoints(200, 1000.0, 3)) {
      Eigen::Vector2d gradient(1, 1), large_gradient(1, 1);
      ASSERT_EQ(terrain.height(p.x(), p.y(), &gradient), 0.0);
      ASSERT_EQ(terrain.largeScale(p.x(), p.y(), &large_gradient), 0.0);
      ASSERT_EQ(gradient, Eigen::Vector2d::Zero());
      ASSERT_EQ(large_gradient, Eigen::Vector2d::Zero());
      ASSERT_EQ(terrain.normal(p.x(), p.y()), Eigen::Vector3d(0, 0, 1));
    }
    TerrainHit hit;
    ASSERT_TRUE(terrain.intersectRay(Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(0.2, -0.1, -1.0), 100.0, &hit));
    EXPECT_EQ(hit.t, 3.0);
    EXPECT_EQ(hit.point.z(), 0.0);
  }
}

TEST(Terrain, EveryTermsGradientMatchesCentralDifferences) {
  struct Case {
    const char* name;
    TerrainParams params;
    bool on_rocks;
  };
  const std::vector<Case> cases = {
      {"slope", only(7.0, 0, 0, 0, 0), false},      {"relief", only(0, 0.8, 0, 0, 0), false},
      {"roughness", only(0, 0, 0.15, 0, 0), false}, {"rocks", only(0, 0, 0, 0.35, 0.1), true},
      {"all terms", roughTerrain(), false},         {"all terms, on rocks", roughTerrain(), true},
  };
  for (const Case& c : cases) {
    const SeabedTerrain terrain(c.params);
    ASSERT_FALSE(terrain.isFlat()) << c.name;
    const auto points = c.on_rocks ? pointsOnRocks(terrain, 300) : randomPoints(2000, 60.0, 11);
    ASSERT_GE(points.size(), 100u) << c.name;
    const double worst = worstGradientError(terrain, points, false);
    const double worst_large = worstGradientError(terrain, points, true);
    std::cout << c.name << ": worst |gradient - central difference| " << worst << ", large scale " << worst_large
              << "\n";
    EXPECT_LT(worst, 2e-9) << c.name;         // measured up to 9.2e-10 (h = 1e-5: truncation and rounding)
    EXPECT_LT(worst_large, 4e-10) << c.name;  // measured up to 2.0e-10
  }
}

TEST(Terrain, HeightIsTheDocumentedSumOfTheWaves) {
  // The truth file lists the waves as amplitude * sin(2 pi (sin(dir) x + cos(dir) y) / wavelength + phase).
  const SeabedTerrain terrain(only(3.0, 0.4, 0.08, 0, 0));
  const double s = std::tan(3.0 * kDeg), az = 57.0 * kDeg;
  double worst = 0.0;
  for (const Eigen::Vector2d& p : randomPoints(5000, 500.0, 21)) {
    double h = -s * (std::sin(az) * p.x() + std::cos(az) * p.y());
    for (const auto* waves : {&terrain.reliefWaves(), &terrain.roughnessWaves()}) {
      for (const TerrainWave& w : *waves) {
        const double d = w.direction_deg * kDeg;
        h += w.amplitude * std::sin(2.0 * M_PI * (std::sin(d) * p.x() + std::cos(d) * p.y()) / w.wavelength + w.phase);
      }
    }
    worst = std::max(worst, std::abs(terrain.height(p.x(), p.y()) - h));
  }
  EXPECT_LT(worst, 1e-12);  // the same formula, other rounding (phases up to ~3000 rad)
}

TEST(Terrain, TermsHaveTheirSizes) {
  // Plane: 7 deg downhill towards azimuth 57 (clockwise from north).
  const SeabedTerrain plane(only(7.0, 0, 0, 0, 0));
  Eigen::Vector2d gradient;
  plane.height(3.0, -2.0, &gradient);
  const Eigen::Vector2d downhill(std::sin(57.0 * kDeg), std::cos(57.0 * kDeg));
  EXPECT_NEAR(gradient.dot(downhill), -std::tan(7.0 * kDeg), 1e-15);
  EXPECT_NEAR(gradient.dot(Eigen::Vector2d(-downhill.y(), downhill.x())), 0.0, 1e-15);
  EXPECT_EQ(plane.height(0.0, 0.0), 0.0);

  // Relief: |relief| <= amplitude, reaching most of it; three directions; the large scale is
  // the plane plus the relief.
  const SeabedTerrain relief(only(0, 0.5, 0, 0, 0));
  ASSERT_EQ(relief.reliefWaves().size(), 3u);
  double peak = 0.0;
  for (const Eigen::Vector2d& p : randomPoints(40000, 200.0, 5)) {
    peak = std::max(peak, std::abs(relief.height(p.x(), p.y())));
  }
  EXPECT_LE(peak, 0.5);
  EXPECT_GT(peak, 0.4);
  EXPECT_EQ(relief.reliefWaves()[0].wavelength, 25.0);
  const SeabedTerrain rough(roughTerrain());
  const SeabedTerrain rough_large(only(2.0, 0.25, 0, 0, 0));
  for (const Eigen::Vector2d& p : randomPoints(100, 50.0, 6)) {
    EXPECT_NEAR(rough.largeScale(p.x(), p.y()), rough_large.height(p.x(), p.y()), 1e-15);
  }

  // Roughness: the rms height over a large area, wavelengths 1-5 m.
  const SeabedTerrain roughness(only(0, 0, 0.1, 0, 0));
  ASSERT_EQ(roughness.roughnessWaves().size(), 5u);
  double sum_sq = 0.0;
  const auto points = randomPoints(40000, 300.0, 8);
  for (const Eigen::Vector2d& p : points) sum_sq += std::pow(roughness.height(p.x(), p.y()), 2);
  EXPECT_NEAR(std::sqrt(sum_sq / points.size()), 0.1, 0.005);
  for (const TerrainWave& w : roughness.roughnessWaves()) {
    EXPECT_GE(w.wavelength, 0.9);
    EXPECT_LE(w.wavelength, 5.4);
  }

  // Rocks: density, heights, radii, inside their cell.
  const SeabedTerrain rocks(only(0, 0, 0, 0.3, 0.05));
  int count = 0;
  const int cells = 60;
  for (int64_t i = 0; i < cells; ++i) {
    for (int64_t j = 0; j < cells; ++j) {
      const auto rock = rocks.rockInCell(i, j);
      if (!rock) continue;
      ++count;
      ASSERT_GE(rock->height, 0.15);
      ASSERT_LE(rock->height, 0.3);
      ASSERT_GE(rock->radius, 2.5 * rock->height);
      ASSERT_LE(rock->radius, 3.5 * rock->height);
      const double c = SeabedTerrain::kRockCell;
      ASSERT_GE(rock->centre.x() - rock->radius, i * c);
      ASSERT_LE(rock->centre.x() + rock->radius, (i + 1) * c);
      ASSERT_GE(rock->centre.y() - rock->radius, j * c);
      ASSERT_LE(rock->centre.y() + rock->radius, (j + 1) * c);
      ASSERT_NEAR(rocks.height(rock->centre.x(), rock->centre.y()), rock->height, 1e-15);
    }
  }
  const double area = std::pow(cells * SeabedTerrain::kRockCell, 2);
  EXPECT_NEAR(count / area, 0.05, 0.005);
}

TEST(Terrain, SameSeedSameTerrain) {
  const SeabedTerrain a(roughTerrain()), b(roughTerrain());
  TerrainParams other = roughTerrain();
  other.seed += 1;
  const SeabedTerrain c(other);
  double difference = 0.0;
  for (const Eigen::Vector2d& p : randomPoints(500, 30.0, 9)) {
    ASSERT_EQ(a.height(p.x(), p.y()), b.height(p.x(), p.y()));
    difference += std::abs(a.height(p.x(), p.y()) - c.height(p.x(), p.y()));
  }
  EXPECT_GT(difference / 500, 0.05);
}

TEST(Terrain, RejectsImpossibleParameters) {
  EXPECT_THROW(SeabedTerrain(only(-1, 0, 0, 0, 0)), std::invalid_argument);
  EXPECT_THROW(SeabedTerrain(only(0, -0.1, 0, 0, 0)), std::invalid_argument);
  EXPECT_THROW(SeabedTerrain(only(0, 0, 0, 0.5, 0.01)), std::invalid_argument);  // too tall for its cell
  EXPECT_THROW(SeabedTerrain(only(0, 0, 0, 0.2, 0.2)), std::invalid_argument);   // more than one per cell
}

// Rays from 1-6 m above rough ground, up to 60 deg off the vertical: the hit lies on the
// surface, and nothing of the surface lies between the origin and the hit (dense sampling).
TEST(Terrain, RayHitsAreOnTheSurfaceAndTheFirstCrossing) {
  const SeabedTerrain terrain(roughTerrain());
  Rng rng(12);
  double worst_on_surface = 0.0, worst_before = 1e9;
  int hits = 0;
  for (int k = 0; k < 400; ++k) {
    const double x = rng.uniform(-30, 30), y = rng.uniform(-30, 30);
    const Eigen::Vector3d origin(x, y, terrain.height(x, y) + rng.uniform(1.0, 6.0));
    const double off_vertical = rng.uniform(0.0, 60.0) * kDeg, azimuth = rng.uniform(0.0, 2.0 * M_PI);
    const Eigen::Vector3d direction =
        1.3 * Eigen::Vector3d(std::sin(off_vertical) * std::cos(azimuth), std::sin(off_vertical) * std::sin(azimuth),
                              -std::cos(off_vertical));
    TerrainHit hit;
    ASSERT_TRUE(terrain.intersectRay(origin, direction, 60.0, &hit)) << k;
    ++hits;
    Eigen::Vector2d gradient;
    const double h = terrain.height(hit.point.x(), hit.point.y(), &gradient);
    worst_on_surface = std::max(worst_on_surface, std::abs(hit.point.z() - h));
    EXPECT_LT((gradient - hit.gradient).norm(), 1e-3);
    const double step = 0.001 / direction.norm();  // 1 mm
    for (double t = 0.0; t < hit.t - 2.0 * step; t += step) {
      const Eigen::Vector3d p = origin + t * direction;
      worst_before = std::min(worst_before, p.z() - terrain.height(p.x(), p.y()));
    }
    // The same ray with a guess (a neighbouring pixel's hit) finds the same crossing.
    TerrainHit guessed;
    ASSERT_TRUE(terrain.intersectRay(origin, direction, 60.0, &guessed, hit.t * 1.01));
    EXPECT_NEAR(guessed.t * direction.norm(), hit.t * direction.norm(), 1e-6);
  }
  std::cout << hits << " rays: worst |z - h| at the hit " << worst_on_surface << " m, lowest point before it "
            << worst_before << " m above the surface\n";
  EXPECT_LT(worst_on_surface, 2e-8);  // measured 9.3e-9
  EXPECT_GT(worst_before, -1e-6);
  // From under the seabed, upwards or out of range: no hit.
  TerrainHit hit;
  const Eigen::Vector3d down(0, 0, -1);
  EXPECT_FALSE(terrain.intersectRay(Eigen::Vector3d(0, 0, terrain.height(0, 0) - 0.05), down, 50, &hit));
  EXPECT_FALSE(terrain.intersectRay(Eigen::Vector3d(0, 0, 3), Eigen::Vector3d(0.1, 0, 1), 50, &hit));
  EXPECT_FALSE(terrain.intersectRay(Eigen::Vector3d(0, 0, 3), Eigen::Vector3d(0, 0, -1), 1.5, &hit));
}

TEST(Terrain, GrazingRayPastARockSeesItsFlank) {
  // A ray at 70 deg from the vertical aimed at a rock's side: the hit is on the rock, before
  // the point where the ray would meet the ground without the rock.
  const SeabedTerrain terrain(only(0, 0, 0, 0.4, 0.1));
  std::optional<TerrainRock> rock;
  for (int64_t i = 0; i < 10 && !rock; ++i) rock = terrain.rockInCell(i, 0);
  ASSERT_TRUE(rock);
  const double elevation = 20.0 * kDeg;
  const Eigen::Vector3d direction(std::cos(elevation), 0.0, -std::sin(elevation));
  const Eigen::Vector3d target(rock->centre.x(), rock->centre.y(), 0.5 * rock->height);
  const Eigen::Vector3d origin = target - 3.0 * direction;
  TerrainHit hit;
  ASSERT_TRUE(terrain.intersectRay(origin, direction, 20.0, &hit));
  EXPECT_LT(hit.t, 3.0);
  EXPECT_GT(hit.point.z(), 0.05);
  EXPECT_LT((hit.point.head<2>() - rock->centre).norm(), rock->radius);
  EXPECT_NEAR(hit.point.z(), terrain.height(hit.point.x(), hit.point.y()), 1e-6);
}

TEST(Sonar, SlantRangeToASlopedPlaneAndToARock) {
  const double slope = 10.0 * kDeg, azimuth = 30.0 * kDeg;
  TerrainParams params;
  params.slope_deg = 10.0;
  params.slope_azimuth_deg = 30.0;
  const SeabedTerrain terrain(params);
  Eigen::Isometry3d T_b_s = Eigen::Isometry3d::Identity();
  T_b_s.linear() =
      (Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  T_b_s.translation() = Eigen::Vector3d(0.1, 0.08, -0.12);
  Rng rng(3);
  double worst = 0.0;
  for (int k = 0; k < 100; ++k) {
    Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
    T_w_b.linear() = Eigen::AngleAxisd(rng.uniform(-M_PI, M_PI), Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                     Eigen::AngleAxisd(rng.uniform(-0.1, 0.1), Eigen::Vector3d::UnitY()).toRotationMatrix();
    T_w_b.translation() = Eigen::Vector3d(rng.uniform(-30, 30), rng.uniform(-30, 30), rng.uniform(-3, 8));
    // Analytic: the plane z = -tan(slope) (u . xy), u the downhill direction.
    const Eigen::Isometry3d T_w_s = T_w_b * T_b_s;
    const Eigen::Vector3d o = T_w_s.translation(), b = T_w_s.linear().col(2);
    const Eigen::Vector2d u(std::sin(azimuth), std::cos(azimuth));
    const double expected =
        -(o.z() + std::tan(slope) * u.dot(o.head<2>())) / (b.z() + std::tan(slope) * u.dot(b.head<2>()));
    if (expected <= 0.0) continue;  // the vehicle would be under the seabed
    worst = std::max(worst, std::abs(SonarSimulator::trueRange(T_w_b, T_b_s, terrain, 50.0) - expected));
  }
  EXPECT_LT(worst, 1e-9);

  // A rock under a vertical beam shortens the range by its height.
  const SeabedTerrain rocky(only(0, 0, 0, 0.3, 0.1));
  std::optional<TerrainRock> rock;
  for (int64_t i = 0; i < 10 && !rock; ++i) rock = rocky.rockInCell(i, 2);
  ASSERT_TRUE(rock);
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
  T_w_b.translation() = Eigen::Vector3d(rock->centre.x(), rock->centre.y(), 3.0);
  const Eigen::Isometry3d down(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()));
  EXPECT_NEAR(SonarSimulator::trueRange(T_w_b, down, rocky, 50.0), 3.0 - rock->height, 1e-9);
  // ... and the simulator uses it; out of range: +inf.
  SonarSimulator sonar(SonarParams(), down, 1, std::make_shared<const SeabedTerrain>(rocky));
  EXPECT_NEAR(sonar.measure(T_w_b).true_range, 3.0 - rock->height, 1e-9);
  T_w_b.translation().z() = 60.0;
  EXPECT_TRUE(std::isinf(sonar.measure(T_w_b).range));
}

TEST(Pressure, NoiseFreeValueIsTheDepthOfThePort) {
  WaterColumn water;
  water.surface_z = 27.5;
  water.atmospheric_pa = 101325.0;
  water.density = 1025.0;
  water.gravity = 9.81;
  PressureParams params;
  params.noise_std_pa = 0.0;
  Eigen::Isometry3d T_b_p = Eigen::Isometry3d::Identity();
  T_b_p.translation() = Eigen::Vector3d(-0.3, 0.02, 0.1);
  PressureSimulator sensor(params, T_b_p, water, 5);
  vims::PressureCalibration calibration;
  calibration.atmospheric_pa = water.atmospheric_pa;
  calibration.water_density = water.density;
  Rng rng(4);
  for (int k = 0; k < 50; ++k) {
    Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
    T_w_b.linear() = (Eigen::AngleAxisd(rng.uniform(-3, 3), Eigen::Vector3d::UnitZ()) *
                      Eigen::AngleAxisd(rng.uniform(-0.3, 0.3), Eigen::Vector3d::UnitY()))
                         .toRotationMatrix();
    T_w_b.translation() = Eigen::Vector3d(rng.uniform(-40, 40), rng.uniform(-30, 30), rng.uniform(-3, 8));
    const double z_port = (T_w_b * T_b_p.translation()).z();
    const PressureReading reading = sensor.measure(T_w_b);
    ASSERT_EQ(reading.pressure, reading.true_pressure);
    ASSERT_NEAR(reading.pressure, 101325.0 + 1025.0 * 9.81 * (27.5 - z_port), 1e-8);
    // The contract's conversion gives the port's depth below the surface.
    ASSERT_NEAR(calibration.depthOf(reading.pressure, 9.81), 27.5 - z_port, 1e-11);
  }
}

TEST(Pressure, NoiseAndSpikesHaveTheConfiguredRates) {
  WaterColumn water;
  PressureParams params;
  params.spike_fraction = 0.05;
  PressureSimulator sensor(params, Eigen::Isometry3d::Identity(), water, 9);
  const Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
  const int n = 100000;
  int spikes = 0, clean = 0;
  double sum_sq = 0.0;
  for (int i = 0; i < n; ++i) {
    const PressureReading r = sensor.measure(T_w_b);
    const double error = r.pressure - r.true_pressure;
    if (r.spike) {
      ++spikes;
      ASSERT_GT(std::abs(error), params.spike_min_pa - 500.0);
      ASSERT_LT(std::abs(error), params.spike_max_pa + 500.0);
    } else {
      ++clean;
      sum_sq += error * error;
    }
  }
  EXPECT_NEAR(spikes / double(n), 0.05, 0.003);
  EXPECT_NEAR(std::sqrt(sum_sq / clean), params.noise_std_pa, 0.01 * params.noise_std_pa);
}
