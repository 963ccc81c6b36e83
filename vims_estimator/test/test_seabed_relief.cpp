// SeabedRelief: the seabed's relief learnt from pairs of sonar hits (seabed_relief.h).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "vims_estimator/factors/sonar_depth_factor.h"
#include "vims_estimator/seabed_relief.h"

namespace vims {
namespace {

// Pair residuals drawn from the model the estimator assumes: r ~ N(0, 2 s^2 + m^2 d^2).
void drawPairs(double m, double s, int n, std::mt19937* rng, std::vector<double>* r, std::vector<double>* d) {
  std::uniform_real_distribution<double> distance(0.5, 3.0);
  std::normal_distribution<double> unit(0.0, 1.0);
  for (int i = 0; i < n; ++i) {
    d->push_back(distance(*rng));
    r->push_back(unit(*rng) * std::sqrt(2.0 * s * s + m * m * d->back() * d->back()));
  }
}

TEST(SeabedRelief, MisfitFromPairsRecoversTheRelief) {
  std::mt19937 rng(3);
  for (const double m : {0.05, 0.2, 0.6}) {
    std::vector<double> r, d;
    drawPairs(m, 0.05, 2000, &rng, &r, &d);
    // A median of 2000 pairs: a few per cent scatter (measured 1-4 %).
    EXPECT_NEAR(misfitFromPairs(r, d, 0.05), m, 0.08 * m) << "m = " << m;
  }
}

TEST(SeabedRelief, NoReliefBeyondTheNoiseGivesZero) {
  std::mt19937 rng(4);
  std::vector<double> r, d;
  drawPairs(0.0, 0.05, 2000, &rng, &r, &d);
  // Half the time the noise alone lands the median a hair above the chi-square median.
  EXPECT_LT(misfitFromPairs(r, d, 0.05), 0.01);
  std::vector<double> smaller;
  for (double x : r) smaller.push_back(0.5 * x);
  EXPECT_EQ(misfitFromPairs(smaller, d, 0.05), 0.0);  // smaller than the noise: exactly 0
  EXPECT_EQ(misfitFromPairs({}, {}, 0.05), 0.0);
}

TEST(SeabedRelief, RocksUnderAFewPingsDoNotMoveIt) {
  std::mt19937 rng(5);
  std::vector<double> r, d;
  drawPairs(0.2, 0.05, 2000, &rng, &r, &d);
  const double clean = misfitFromPairs(r, d, 0.05);
  for (std::size_t i = 0; i < r.size(); i += 10) r[i] += 0.8;  // a rock in one ping of 10 % of the pairs
  EXPECT_NEAR(misfitFromPairs(r, d, 0.05), clean, 0.15 * clean);
}

// Hits along a straight track over a sloping seabed with sinusoidal relief: the plane's slope
// is taken out, the relief is measured, and a level seabed without relief gives 0.
TEST(SeabedRelief, HitsAlongATrackOverASlopingSeabed) {
  const Eigen::Vector2d slope(0.07, -0.03);
  auto track = [&](double amplitude, SeabedRelief* relief, std::vector<SeabedSample>* window) {
    for (int i = 0; i < 120; ++i) {
      SeabedSample s;
      s.xy = Eigen::Vector2d(0.25 * i, 0.05 * i);
      s.slope = slope;
      s.height = -3.0 + slope.dot(s.xy) + amplitude * std::sin(2.0 * M_PI * s.xy.x() / 2.0);
      if (i < 110) {
        relief->addHistory(s);
      } else {
        window->push_back(s);
      }
    }
  };
  SeabedRelief flat(100), rough(100);
  std::vector<SeabedSample> flat_window, rough_window;
  track(0.0, &flat, &flat_window);
  track(0.1, &rough, &rough_window);
  EXPECT_EQ(flat.historySize(), 100u);  // bounded: the oldest 10 were dropped
  const auto none = flat.estimate(flat_window, 0.02, 1.0, 30);
  ASSERT_TRUE(none.has_value());
  EXPECT_EQ(none->misfit_per_m, 0.0);
  const auto some = rough.estimate(rough_window, 0.02, 1.0, 30);
  ASSERT_TRUE(some.has_value());
  // 10 cm of relief with a 2 m wavelength: pairs 0.5-2 m apart differ by up to 20 cm, so the
  // growth is of order 0.1 m/m (measured 0.13).
  EXPECT_GT(some->misfit_per_m, 0.05);
  EXPECT_LT(some->misfit_per_m, 0.25);
  EXPECT_GT(some->pairs, 30);
  // The features' distances decide which pairs count: the track is 30 m long, no pair is 50-200 m apart.
  EXPECT_FALSE(rough.estimate(rough_window, 0.02, 100.0, 30).has_value());
  EXPECT_FALSE(rough.estimate(rough_window, 0.02, 0.0, 30).has_value());
}

TEST(SeabedRelief, NonFiniteHitsAreIgnored) {
  SeabedRelief relief(10);
  SeabedSample bad;
  bad.height = std::nan("");
  relief.addHistory(bad);
  EXPECT_EQ(relief.historySize(), 0u);
}

TEST(SeabedRelief, GrowthOfTheFactorsSigma) {
  SonarDepthOptions options;
  EXPECT_DOUBLE_EQ(options.misfitPerM(std::nullopt, 10), options.misfit_per_m);
  // Learnt: the relief times sqrt((N + 1) / 2) for the N features sharing the anchor's hit,
  // misfit_per_m where that is less.
  options.misfit_per_m = 0.1;
  EXPECT_DOUBLE_EQ(options.misfitPerM(0.1, 7), 0.1 * 2.0);
  EXPECT_DOUBLE_EQ(options.misfitPerM(0.0, 50), 0.1);
  options.misfit_per_m = 0.0;
  EXPECT_DOUBLE_EQ(options.misfitPerM(0.0, 50), 0.0);
  options.learn_misfit = false;
  EXPECT_DOUBLE_EQ(options.misfitPerM(0.1, 7), options.misfit_per_m);
}

// The hit a feature is tied to with tie_to_nearest_hit: the nearest kept one, only if it is
// nearer than the anchor's own hit (`within`).
TEST(SeabedRelief, NearestKeptHitIsTheNearestWithinTheOwnHitsDistance) {
  SeabedRelief relief(3);
  EXPECT_FALSE(relief.nearestKeptHit(Eigen::Vector2d::Zero(), 10.0));
  for (const double x : {0.0, 1.0, 2.0, 3.0}) {  // 4 hits into a history of 3: x = 0 is dropped
    SeabedSample s;
    s.xy = Eigen::Vector2d(x, 0.5);
    s.height = -x;
    relief.addHistory(s);
  }
  const auto hit = relief.nearestKeptHit(Eigen::Vector2d(0.1, 0.5), 5.0);
  ASSERT_TRUE(hit);
  EXPECT_EQ(hit->first, 0u);  // x = 1, the oldest kept
  EXPECT_NEAR(hit->second, 0.9, 1e-12);
  EXPECT_DOUBLE_EQ(relief.keptHit(hit->first).height, -1.0);
  EXPECT_FALSE(relief.nearestKeptHit(Eigen::Vector2d(0.1, 0.5), 0.9));  // the own hit is as near
  const auto middle = relief.nearestKeptHit(Eigen::Vector2d(2.2, 0.4), 5.0);
  ASSERT_TRUE(middle);
  EXPECT_EQ(middle->first, 1u);
  EXPECT_NEAR(middle->second, std::hypot(0.2, 0.1), 1e-12);
}

}  // namespace
}  // namespace vims
