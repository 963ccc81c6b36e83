#include "vims_common/log.h"

#include <cmath>
#include <iostream>

namespace vims {

const char* logLevelName(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug:
      return "DEBUG";
    case LogLevel::kInfo:
      return "INFO";
    case LogLevel::kWarn:
      return "WARN";
    case LogLevel::kError:
      return "ERROR";
  }
  return "?";
}

std::shared_ptr<Logger> Logger::stderrLogger(LogLevel min_level) {
  return std::make_shared<Logger>(
      [](LogLevel level, const std::string& component, const std::string& message) {
        std::cerr << "[" << logLevelName(level) << "] [" << component << "] " << message << std::endl;
      },
      min_level);
}

std::shared_ptr<Logger> Logger::nullLogger() {
  return std::make_shared<Logger>([](LogLevel, const std::string&, const std::string&) {}, LogLevel::kError);
}

void Logger::log(LogLevel level, const std::string& component, const std::string& message) {
  if (level < min_level_) return;
  std::lock_guard<std::mutex> lock(mutex_);
  sink_(level, component, message);
}

void Logger::warnThrottled(const std::string& component, const std::string& key, double t, double period_s,
                           const std::string& message) {
  std::string text;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ThrottleState& state = throttle_[component + "/" + key];
    // A clock that jumped backwards (bag loop) must not silence the warning forever.
    if (t >= state.last_t && t - state.last_t < period_s) {
      ++state.suppressed;
      return;
    }
    text = message;
    if (state.suppressed > 0) text += " (" + std::to_string(state.suppressed) + " similar suppressed)";
    state.last_t = t;
    state.suppressed = 0;
  }
  log(LogLevel::kWarn, component, text);
}

}  // namespace vims
