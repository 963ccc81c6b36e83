// Unit tests of the sonar altitude filter on synthetic range sequences whose truth is known.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "vims_sonar/sonar_altitude_filter.h"
#include "vims_sonar/sonar_csv_writer.h"

using namespace vims;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

SonarCalibration calibration(double noise = 0.02) {
  SonarCalibration c;
  c.range_noise_std = noise;
  c.min_range = 0.1;
  c.max_range = 30.0;
  return c;
}

/// A slant range that changes like the simulator's: slow altitude changes plus pitch sway.
double trueRange(double t) { return 2.0 + 0.6 * std::sin(0.15 * t) + 0.05 * std::sin(2.0 * M_PI * 0.4 * t); }

struct Injected {
  SonarRange sample;
  double truth;
  bool outlier;
  bool dropout;
};

/// 10 Hz ranges with 2 cm noise, 3 % multipath outliers (1.3-2x) and 1 % dropouts (+inf).
std::vector<Injected> simulate(double duration, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Injected> out;
  for (int k = 0; k < static_cast<int>(duration * 10.0); ++k) {
    const double t = 100.0 + 0.1 * k;
    Injected s;
    s.truth = trueRange(t);
    s.sample.t = t;
    s.sample.range = s.truth + noise(rng);
    s.outlier = s.dropout = false;
    const double draw = u(rng);
    if (draw < 0.03) {
      s.sample.range = s.truth * (1.3 + 0.7 * u(rng));
      s.outlier = true;
    } else if (draw < 0.04) {
      s.sample.range = kInf;
      s.dropout = true;
    }
    out.push_back(s);
  }
  return out;
}

std::vector<SonarFilterResult> runAll(SonarAltitudeFilter& filter, const std::vector<SonarRange>& in) {
  std::vector<SonarFilterResult> results;
  for (const auto& s : in) filter.feed(s, &results);
  filter.flush(&results);
  return results;
}

std::vector<SonarRange> samplesOf(const std::vector<Injected>& in) {
  std::vector<SonarRange> out;
  for (const auto& s : in) out.push_back(s.sample);
  return out;
}

struct CapturedLog {
  std::vector<std::string> warnings;
  LoggerPtr logger() {
    return std::make_shared<Logger>(
        [this](LogLevel level, const std::string&, const std::string& m) {
          if (level == LogLevel::kWarn) warnings.push_back(m);
        },
        LogLevel::kDebug);
  }
};

}  // namespace

TEST(SonarAltitudeFilter, RejectsInjectedOutliersAndKeepsGoodSamples) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const auto seq = simulate(600.0, seed);
    SonarAltitudeFilter filter(SonarFilterOptions{}, calibration());
    const auto results = runAll(filter, samplesOf(seq));
    ASSERT_EQ(results.size(), seq.size());
    long outliers = 0, rejected = 0, good = 0, lost = 0, n_accepted = 0;
    double sq_error = 0.0;
    for (std::size_t i = 0; i < seq.size(); ++i) {
      ASSERT_DOUBLE_EQ(results[i].t, seq[i].sample.t) << "results must come out in input order";
      if (seq[i].dropout) {
        EXPECT_EQ(results[i].status, SonarStatus::kDropout);
        continue;
      }
      if (seq[i].outlier) {
        ++outliers;
        if (!results[i].accepted) ++rejected;
      } else {
        ++good;
        if (!results[i].accepted) ++lost;
      }
      if (results[i].accepted) {
        sq_error += std::pow(results[i].filtered - seq[i].truth, 2);
        ++n_accepted;
      }
    }
    // The median of the trend-moved window is less noisy than a raw range (2 cm) even with the
    // 5 cm pitch sway that a straight line cannot follow exactly.
    EXPECT_LT(std::sqrt(sq_error / n_accepted), 0.02) << "seed " << seed;
    EXPECT_GE(static_cast<double>(rejected) / outliers, 0.95) << "seed " << seed;
    EXPECT_LT(static_cast<double>(lost) / good, 0.01) << "seed " << seed;
    EXPECT_EQ(filter.stats().resets, 0) << "isolated dropouts and outliers must not reset the filter";
  }
}

TEST(SonarAltitudeFilter, FollowsARampWithoutLag) {
  SonarAltitudeFilter filter(SonarFilterOptions{}, calibration(0.01));
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<SonarFilterResult> results;
  double bias = 0.0;
  int n = 0;
  for (int k = 0; k < 300; ++k) {
    const double t = 0.1 * k;
    const double truth = 3.0 - 0.08 * t;  // descending at 0.08 m/s
    filter.feed({t, truth + noise(rng)}, &results);
    if (!results.empty() && results.back().t == t && k > 20) {
      ASSERT_TRUE(results.back().accepted) << "t=" << t;
      bias += results.back().filtered - truth;
      ++n;
    }
  }
  ASSERT_GT(n, 250);
  // A plain running median of 7 samples would lag by 3 samples = 2.4 cm here.
  EXPECT_NEAR(bias / n, 0.0, 0.005);
}

TEST(SonarAltitudeFilter, DropoutsOfEveryKindAreReportedAndNeverPropagateNaN) {
  SonarAltitudeFilter filter(SonarFilterOptions{}, calibration());
  std::vector<SonarFilterResult> results;
  for (int k = 0; k < 20; ++k) filter.feed({0.1 * k, 2.0}, &results);
  ASSERT_TRUE(filter.locked());
  const double bad[] = {kInf, std::numeric_limits<double>::quiet_NaN(), 0.05, 45.0, -kInf};
  double t = 2.0;
  for (double r : bad) {
    results.clear();
    filter.feed({t, r}, &results);
    t += 0.1;
    ASSERT_EQ(results.size(), 1u);
    EXPECT_EQ(results[0].status, SonarStatus::kDropout) << r;
    EXPECT_FALSE(results[0].accepted);
    ASSERT_TRUE(results[0].has_estimate);
    EXPECT_TRUE(std::isfinite(results[0].filtered));
    EXPECT_NEAR(results[0].filtered, 2.0, 1e-9);
  }
  results.clear();
  filter.feed({t, 2.01}, &results);
  ASSERT_EQ(results.size(), 1u);
  EXPECT_TRUE(results[0].accepted) << "the filter keeps its lock through a few dropouts";
  EXPECT_EQ(filter.stats().dropouts, 5);
}

TEST(SonarAltitudeFilter, ReacquiresAfterAGapWithoutTakingAnOutlierAsTruth) {
  CapturedLog log;
  SonarAltitudeFilter filter(SonarFilterOptions{}, calibration(), log.logger());
  std::vector<SonarFilterResult> results;
  for (int k = 0; k < 30; ++k) filter.feed({0.1 * k, 2.0}, &results);
  ASSERT_TRUE(filter.locked());
  // 3 s without messages; meanwhile the vehicle rose by 0.5 m. The first sample after the gap
  // is a multipath return.
  results.clear();
  const std::vector<double> after = {2.5 * 1.6, 2.5, 2.49, 2.51, 2.5, 2.5};
  for (std::size_t i = 0; i < after.size(); ++i) filter.feed({6.0 + 0.1 * i, after[i]}, &results);
  ASSERT_EQ(results.size(), after.size()) << "every held sample is decided once the trend is back";
  EXPECT_FALSE(results[0].accepted);
  EXPECT_EQ(results[0].status, SonarStatus::kReset) << "the multipath return triggered the reset";
  for (std::size_t i = 1; i < after.size(); ++i) {
    EXPECT_TRUE(results[i].accepted) << i;
    EXPECT_NEAR(results[i].filtered, 2.5, 0.02);
  }
  EXPECT_EQ(filter.stats().resets, 1);
  EXPECT_FALSE(log.warnings.empty());
}

TEST(SonarAltitudeFilter, RecoversFromASustainedStepAfterMaxGap) {
  // The seabed drops by 1 m (the vehicle passes a ledge): every range is rejected until max_gap_s
  // passes without an accepted sample, then the filter re-acquires the new level.
  SonarAltitudeFilter filter(SonarFilterOptions{}, calibration());
  std::vector<SonarFilterResult> results;
  for (int k = 0; k < 30; ++k) filter.feed({0.1 * k, 2.0}, &results);
  results.clear();
  for (int k = 30; k < 60; ++k) filter.feed({0.1 * k, 3.0}, &results);
  ASSERT_FALSE(results.empty());
  EXPECT_TRUE(results.back().accepted);
  EXPECT_NEAR(results.back().filtered, 3.0, 1e-9);
  EXPECT_EQ(filter.stats().resets, 1);
}

// A fish swims through the beam: three short returns at 1.2 m over a 3.5 m seabed are outliers,
// said once in the log, and the filtered range stays on the seabed.
TEST(SonarAltitudeFilter, AFishUnderTheBeamIsAnOutlierWithAWarning) {
  CapturedLog log;
  SonarAltitudeFilter filter(SonarFilterOptions{}, calibration(), log.logger());
  std::vector<SonarFilterResult> results;
  for (int k = 0; k < 30; ++k) filter.feed({0.1 * k, 3.5}, &results);
  ASSERT_TRUE(filter.locked());
  results.clear();
  for (int k = 30; k < 33; ++k) filter.feed({0.1 * k, 1.2}, &results);
  for (int k = 33; k < 40; ++k) filter.feed({0.1 * k, 3.5}, &results);
  ASSERT_EQ(results.size(), 10u);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(results[k].status, SonarStatus::kOutlier) << k;
  for (const auto& r : results) EXPECT_NEAR(r.filtered, 3.5, 1e-9);
  EXPECT_TRUE(results.back().accepted);
  int said = 0;
  for (const auto& w : log.warnings) said += w.find("a fish or a rock under the beam") != std::string::npos;
  EXPECT_EQ(said, 1);  // throttled: one line for the three
}

TEST(SonarAltitudeFilter, ClockGoingBackwardsResetsWithAWarning) {
  CapturedLog log;
  SonarAltitudeFilter filter(SonarFilterOptions{}, calibration(), log.logger());
  std::vector<SonarFilterResult> results;
  for (int k = 0; k < 30; ++k) filter.feed({10.0 + 0.1 * k, 2.0 + 0.01 * k}, &results);
  ASSERT_TRUE(filter.locked());
  results.clear();
  for (int k = 0; k < 10; ++k) filter.feed({10.0 + 0.1 * k, 2.0 + 0.01 * k}, &results);  // the bag loops
  ASSERT_EQ(results.size(), 10u);
  EXPECT_EQ(filter.stats().resets, 1);
  EXPECT_TRUE(results.back().accepted);
  bool warned = false;
  for (const auto& w : log.warnings) warned |= w.find("backwards") != std::string::npos;
  EXPECT_TRUE(warned);
}

TEST(SonarAltitudeFilter, DuplicateStampsAreDropouts) {
  SonarAltitudeFilter filter(SonarFilterOptions{}, calibration());
  std::vector<SonarFilterResult> results;
  for (int k = 0; k < 10; ++k) filter.feed({0.1 * k, 2.0}, &results);
  results.clear();
  filter.feed({0.9, 2.0}, &results);
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].status, SonarStatus::kDropout);
  EXPECT_EQ(filter.stats().resets, 0);
}

TEST(SonarAltitudeFilter, FlushDecidesHeldSamplesAsWarmingUp) {
  SonarAltitudeFilter filter(SonarFilterOptions{}, calibration());
  std::vector<SonarFilterResult> results;
  filter.feed({0.0, 2.0}, &results);
  filter.feed({0.1, kInf}, &results);
  filter.feed({0.2, 2.0}, &results);
  EXPECT_TRUE(results.empty()) << "held until acquisition";
  filter.flush(&results);
  ASSERT_EQ(results.size(), 3u);
  EXPECT_EQ(results[0].status, SonarStatus::kWarmingUp);
  EXPECT_EQ(results[1].status, SonarStatus::kDropout);
  EXPECT_EQ(results[2].status, SonarStatus::kWarmingUp);
  for (const auto& r : results) EXPECT_FALSE(r.has_estimate);
}

TEST(SonarAltitudeFilter, AcquisitionRejectsAnOutlierAtEitherEnd) {
  for (int bad_index : {0, 3}) {
    SonarAltitudeFilter filter(SonarFilterOptions{}, calibration());
    std::vector<SonarFilterResult> results;
    for (int k = 0; k < 8; ++k) filter.feed({0.1 * k, k == bad_index ? 1.5 * 1.3 : 1.5}, &results);
    filter.flush(&results);
    ASSERT_EQ(results.size(), 8u);
    for (int k = 0; k < 8; ++k) EXPECT_EQ(results[k].accepted, k != bad_index) << bad_index << " " << k;
  }
}

TEST(SonarCsv, HeaderAndRows) {
  // The file itself (header first, checked writes) is CsvFile's (vims_common/test/test_csv_writer.cpp).
  EXPECT_STREQ(SonarCsv::header(), "t,raw_range,filtered_range,accepted,status");
  EXPECT_EQ(SonarCsv::row({1.5, 2.0, 2.01, true, true, SonarStatus::kOk}), "1.500000,2.0000,2.0100,1,ok");
  EXPECT_EQ(SonarCsv::row({1.6, kInf, 0.0, false, false, SonarStatus::kDropout}), "1.600000,inf,nan,0,dropout");
  EXPECT_THROW(SonarCsvWriter("/nonexistent_dir/x.csv"), std::runtime_error);
}

TEST(SonarAltitudeFilter, NonFiniteStampIsADropoutAndKeepsOrder) {
  SonarAltitudeFilter filter(SonarFilterOptions{}, calibration());
  std::vector<SonarFilterResult> results;
  for (int k = 0; k < 10; ++k) filter.feed({0.1 * k, 2.0}, &results);
  results.clear();
  filter.feed({std::numeric_limits<double>::quiet_NaN(), 2.0}, &results);
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].status, SonarStatus::kDropout);
  results.clear();
  filter.feed({1.0, 2.0}, &results);
  ASSERT_EQ(results.size(), 1u);
  EXPECT_TRUE(results[0].accepted) << "a bad stamp must not disturb the trend";
}
