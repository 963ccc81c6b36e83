#pragma once
/// @file point_keypoint_distance.h
/// @brief Descriptor distances between described 3D points and candidate keypoints, shared by
/// the 2NN matching, the guided matching and the covisibility check (loop_detector.cpp,
/// guided_matching.cpp). Internal to vims_pose_graph_core.

#include <algorithm>
#include <cstdint>
#include <vector>

#include "vims_pose_graph/loop_detector.h"

namespace vims {

/// Descriptor indices of each point.
inline std::vector<std::vector<uint32_t>> descriptorsByPoint(const DescribedPoints& points) {
  std::vector<std::vector<uint32_t>> by_point(points.numPoints());
  for (uint32_t d = 0; d < points.descriptors.size(); ++d) {
    const uint32_t p = points.point_of_descriptor[d];
    if (p < by_point.size()) by_point[p].push_back(d);
  }
  return by_point;
}

/// Distance of a described point to a keypoint: the best over the point's descriptors whose
/// level the window admits for the keypoint's octave (257: none admitted).
inline int pointDistance(const DescribedPoints& points, const std::vector<uint32_t>& descriptor_ids,
                         const BinaryDescriptor& other, int octave, const LevelWindow& levels) {
  int best = 257;
  for (uint32_t d : descriptor_ids) {
    if (!levels.admits(points.level_of_descriptor[d], octave)) continue;
    best = std::min(best, hammingDistance(points.descriptors[d], other));
  }
  return best;
}

/// One point per keypoint: of the matches claiming a keypoint the closest stays (ties: the
/// earlier one); the order of `matches` is kept.
inline std::vector<PointMatch> closestMatchPerKeypoint(const std::vector<PointMatch>& matches, size_t num_keypoints) {
  std::vector<int> owner(num_keypoints, -1);  // index in `matches` of each keypoint's owner
  for (size_t i = 0; i < matches.size(); ++i) {
    int& o = owner[matches[i].keypoint];
    if (o < 0 || matches[i].distance < matches[static_cast<size_t>(o)].distance) o = static_cast<int>(i);
  }
  std::vector<PointMatch> unique;
  unique.reserve(matches.size());
  for (size_t i = 0; i < matches.size(); ++i)
    if (owner[matches[i].keypoint] == static_cast<int>(i)) unique.push_back(matches[i]);
  return unique;
}

}  // namespace vims
