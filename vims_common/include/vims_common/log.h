#pragma once
/// @file log.h
/// @brief A small leveled logger for the ROS-free core libraries.
///
/// Core code logs through a Logger it is given (never rosconsole): the ROS nodes hand in a
/// logger whose sink forwards to ROS_INFO/WARN/ERROR, the offline runner one that prints to
/// stderr, and tests one that records lines so they can assert on warnings.
/// Warnings that can repeat at sensor rate use warnThrottled() so logs stay readable.

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>

namespace vims {

enum class LogLevel { kDebug = 0, kInfo = 1, kWarn = 2, kError = 3 };

const char* logLevelName(LogLevel level);

class Logger {
 public:
  using Sink = std::function<void(LogLevel, const std::string& component, const std::string& message)>;

  /// A logger that prints "[LEVEL] [component] message" to stderr from `min_level` up.
  static std::shared_ptr<Logger> stderrLogger(LogLevel min_level = LogLevel::kInfo);
  /// A logger that swallows everything (the default for cores built without one).
  static std::shared_ptr<Logger> nullLogger();

  Logger(Sink sink, LogLevel min_level) : sink_(std::move(sink)), min_level_(min_level) {}

  void log(LogLevel level, const std::string& component, const std::string& message);
  void debug(const std::string& c, const std::string& m) { log(LogLevel::kDebug, c, m); }
  void info(const std::string& c, const std::string& m) { log(LogLevel::kInfo, c, m); }
  void warn(const std::string& c, const std::string& m) { log(LogLevel::kWarn, c, m); }
  void error(const std::string& c, const std::string& m) { log(LogLevel::kError, c, m); }

  /// Logs a warning at most once per `period_s` of *sensor* time `t` per (component, key),
  /// and reports how many were suppressed in between. Sensor time keeps offline runs
  /// deterministic and readable at 100x real time.
  void warnThrottled(const std::string& component, const std::string& key, double t, double period_s,
                     const std::string& message);

  LogLevel minLevel() const { return min_level_; }

 private:
  struct ThrottleState {
    double last_t = -1e300;
    long suppressed = 0;
  };
  Sink sink_;
  LogLevel min_level_;
  std::mutex mutex_;
  std::map<std::string, ThrottleState> throttle_;
};

using LoggerPtr = std::shared_ptr<Logger>;

/// Formats anything streamable: VIMS_STR("x=" << x).
#define VIMS_STR(expr)           \
  ([&]() {                       \
    std::ostringstream vims_os_; \
    vims_os_ << expr;            \
    return vims_os_.str();       \
  }())

}  // namespace vims
