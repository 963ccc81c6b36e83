#include <gtest/gtest.h>

#include <limits>

#include "vims_ros/sonar_conversions.h"

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

vims::SonarFilterResult accepted() {
  vims::SonarFilterResult r;
  r.t = 1234.5;
  r.raw = 2.25;
  r.filtered = 2.125;
  r.has_estimate = true;
  r.accepted = true;
  r.status = vims::SonarStatus::kOk;
  return r;
}

vims::FilteredSonarRange toMsg(const vims::SonarFilterResult& r) {
  vims::FilteredSonarRange msg;
  std::string why;
  EXPECT_TRUE(vims::toFilteredSonarRangeMsg(r, "sonar", &msg, &why)) << why;
  return msg;
}

TEST(SonarConversions, EveryVerdictSurvivesTheRoundTrip) {
  std::vector<vims::SonarFilterResult> verdicts(5, accepted());
  verdicts[1].accepted = false;
  verdicts[1].status = vims::SonarStatus::kOutlier;
  verdicts[1].raw = 3.5;
  verdicts[2].accepted = false;
  verdicts[2].status = vims::SonarStatus::kDropout;
  verdicts[2].raw = kInf;  // no echo (REP 117)
  verdicts[3].accepted = false;
  verdicts[3].has_estimate = false;
  verdicts[3].filtered = kNaN;  // no estimate: goes out as 0
  verdicts[3].status = vims::SonarStatus::kWarmingUp;
  verdicts[4].accepted = false;
  verdicts[4].has_estimate = false;
  verdicts[4].status = vims::SonarStatus::kReset;
  for (const vims::SonarFilterResult& r : verdicts) {
    const vims::FilteredSonarRange msg = toMsg(r);
    EXPECT_EQ(msg.header.frame_id, "sonar");
    vims::SonarFilterResult back;
    std::string why;
    ASSERT_TRUE(vims::toSonarFilterResult(msg, &back, &why)) << why;
    EXPECT_NEAR(back.t, r.t, 1e-6);
    EXPECT_EQ(back.raw, r.raw);
    EXPECT_EQ(back.filtered, r.has_estimate ? r.filtered : 0.0);
    EXPECT_EQ(back.has_estimate, r.has_estimate);
    EXPECT_EQ(back.accepted, r.accepted);
    EXPECT_EQ(back.status, r.status) << vims::sonarStatusName(r.status);
  }
}

TEST(SonarConversions, BadVerdictsAreNotPublished) {
  vims::FilteredSonarRange msg;
  std::string why;
  vims::SonarFilterResult r = accepted();
  r.raw = kNaN;
  EXPECT_FALSE(vims::toFilteredSonarRangeMsg(r, "sonar", &msg, &why));
  r = accepted();
  r.filtered = kInf;
  EXPECT_FALSE(vims::toFilteredSonarRangeMsg(r, "sonar", &msg, &why));
  r = accepted();
  r.t = -1.0;
  EXPECT_FALSE(vims::toFilteredSonarRangeMsg(r, "sonar", &msg, &why));
}

TEST(SonarConversions, BadMessagesAreRejectedWithAReason) {
  vims::SonarFilterResult out;
  std::string why;
  vims::FilteredSonarRange msg = toMsg(accepted());
  msg.status = 9;
  EXPECT_FALSE(vims::toSonarFilterResult(msg, &out, &why));
  EXPECT_NE(why.find("unknown status 9"), std::string::npos) << why;
  msg = toMsg(accepted());
  msg.raw = kNaN;
  EXPECT_FALSE(vims::toSonarFilterResult(msg, &out, &why));
  msg = toMsg(accepted());
  msg.filtered = -1.0;
  EXPECT_FALSE(vims::toSonarFilterResult(msg, &out, &why));
  msg = toMsg(accepted());
  msg.filtered = kNaN;
  EXPECT_FALSE(vims::toSonarFilterResult(msg, &out, &why));
  msg = toMsg(accepted());
  msg.has_estimate = false;  // accepted without an estimate
  EXPECT_FALSE(vims::toSonarFilterResult(msg, &out, &why));
  msg = toMsg(accepted());
  msg.status = vims::FilteredSonarRange::STATUS_OUTLIER;  // accepted outlier
  EXPECT_FALSE(vims::toSonarFilterResult(msg, &out, &why));
  EXPECT_NE(why.find("accepted"), std::string::npos) << why;
}

}  // namespace
