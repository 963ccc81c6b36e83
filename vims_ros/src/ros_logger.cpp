#include "vims_ros/ros_logger.h"

#include <ros/console.h>

namespace vims {

LoggerPtr rosLogger() {
  // Every level is forwarded: rosconsole's own level settings decide what is shown.
  return std::make_shared<Logger>(
      [](LogLevel level, const std::string& component, const std::string& message) {
        switch (level) {
          case LogLevel::kDebug:
            ROS_DEBUG_STREAM_NAMED(component, message);
            break;
          case LogLevel::kInfo:
            ROS_INFO_STREAM_NAMED(component, message);
            break;
          case LogLevel::kWarn:
            ROS_WARN_STREAM_NAMED(component, message);
            break;
          case LogLevel::kError:
            ROS_ERROR_STREAM_NAMED(component, message);
            break;
        }
      },
      LogLevel::kDebug);
}

}  // namespace vims
