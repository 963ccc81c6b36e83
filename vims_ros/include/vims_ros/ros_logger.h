#pragma once
/// @file ros_logger.h
/// @brief A vims::Logger whose sink is rosconsole, for the nodes: the cores log through it
/// and the messages appear as ROS_* lines named after the component (rosconsole filters apply).

#include "vims_common/log.h"

namespace vims {

LoggerPtr rosLogger();

}  // namespace vims
