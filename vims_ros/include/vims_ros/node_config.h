#pragma once
/// @file node_config.h
/// @brief The nodes' `~config_file` parameter: which system configuration files to load.

#include <ros/node_handle.h>

#include <string>
#include <vector>

namespace vims {

/// The files of the private parameter `~config_file`: one path (a string; empty = none) or a list
/// of paths, for vims::SystemConfig::load. Throws ConfigError when it is of another type, and when
/// the node still sets the old `~options_file` (it held one module's keys without a section).
std::vector<std::string> configFilesParam(const ros::NodeHandle& private_nh);

}  // namespace vims
