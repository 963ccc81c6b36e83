#include <gtest/gtest.h>

#include <vector>

#include "vims_common/log.h"

TEST(Logger, ThrottlesBySensorTimeAndCountsSuppressed) {
  std::vector<std::string> lines;
  vims::Logger logger([&](vims::LogLevel, const std::string&, const std::string& m) { lines.push_back(m); },
                      vims::LogLevel::kInfo);
  for (int i = 0; i < 100; ++i) logger.warnThrottled("sonar", "dropout", 0.01 * i, 0.5, "dropout");
  // t = 0.00, 0.50 -> two lines; the second reports the 49 suppressed in between.
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_NE(lines[1].find("49 similar suppressed"), std::string::npos);
  // A backwards jump (bag loop) logs immediately.
  logger.warnThrottled("sonar", "dropout", 0.0, 0.5, "dropout");
  EXPECT_EQ(lines.size(), 3u);
}

TEST(Logger, RespectsMinimumLevel) {
  int count = 0;
  vims::Logger logger([&](vims::LogLevel, const std::string&, const std::string&) { ++count; }, vims::LogLevel::kWarn);
  logger.info("x", "hidden");
  logger.debug("x", "hidden");
  logger.warn("x", "shown");
  logger.error("x", "shown");
  EXPECT_EQ(count, 2);
  EXPECT_EQ(VIMS_STR("a=" << 3), "a=3");
}
