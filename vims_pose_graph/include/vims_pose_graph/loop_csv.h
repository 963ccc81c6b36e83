#pragma once
/// @file loop_csv.h
/// @brief `loops.csv`: one row per loop verification attempt, the format vims_eval reads
/// (vims_eval/src/loops.cpp): header `t_query,t_match,accepted,x,y,z,qx,qy,qz,qw,inliers,
/// mag_distance,bow_score,stage,sigma_x,sigma_y,sigma_z,sigma_yaw_deg,match_in_map`; x..qw is T_match_query
/// (identity before PnP succeeded); mag_distance [T] and bow_score are empty when that stage did
/// not score the pair; sigma_* are LoopAttempt::sigma (position of the query in the match's
/// levelled frame [m], yaw [deg]), empty before PnP succeeded; match_in_map is 1 when the match
/// keyframe is of a loaded map (teach and repeat: t_match is then the teach run's time).

#include <string>

#include "vims_common/csv_writer.h"
#include "vims_pose_graph/loop_detector.h"

namespace vims {

/// The format of `loops.csv` (CsvWriter).
struct LoopCsv {
  using Row = LoopAttempt;
  static const char* header();
  static std::string row(const LoopAttempt& attempt);
};
using LoopCsvWriter = CsvWriter<LoopCsv>;

}  // namespace vims
