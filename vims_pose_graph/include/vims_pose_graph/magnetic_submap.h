#pragma once
/// @file magnetic_submap.h
/// @brief Grouping of magnetic signatures into magnetic submaps (paper, "Magnetic Submaps"):
/// consecutive valid signatures are grouped while the signature stays within a relative
/// variation of the group's first one; a closed group becomes a sparse submap: the smoothed
/// signature at its median member, the keyframe nearest in time to that member (the tied visual
/// submap, whose optimised position the submap follows) and a radius within which every member
/// varies less than the threshold. docs/pose_graph.md, "Magnetic submaps".

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

#include "vims_pose_graph/loop_closing_options.h"

namespace vims {

/// The largest coil index (SignatureWindow::coil) the pose graph and its map file accept: the
/// MagneticSignature message carries it as a uint8.
constexpr int kMaxCoilIndex = 255;

/// A valid signature placed on the trajectory.
struct PlacedSignature {
  double t = 0.0;
  int coil = 0;          ///< SignatureWindow::coil: a group, and so a submap, holds one coil's signatures
  uint32_t session = 0;  ///< map session of the keyframes it was placed with
  Eigen::Vector3d p_odom = Eigen::Vector3d::Zero();         ///< body position at t in the session's VIO frame
  Eigen::Vector3d signature_enu = Eigen::Vector3d::Zero();  ///< amplitude vector [T], ENU
  PoseGraphNodeId nearest_node = 0;                         ///< keyframe nearest in time
};

/// A closed group, before it is stored in the map.
struct MagneticSubmapDraft {
  PoseGraphNodeId tied_node = 0;  ///< keyframe nearest in time to the median member
  double t = 0.0;                 ///< median member's time
  int coil = 0;                   ///< the coil its signature measures
  uint32_t session = 0;
  Eigen::Vector3d signature_enu = Eigen::Vector3d::Zero();  ///< smoothed signature at the median [T]
  Eigen::Vector3d p_odom = Eigen::Vector3d::Zero();         ///< median member's position (VIO frame)
  double radius_m = 0.0;
  uint32_t num_members = 0;
};

/// A magnetic submap in the map. Its world position is its tied keyframe's world position, so
/// it follows the pose graph after every optimisation.
struct MagneticSubmap {
  uint32_t id = 0;
  PoseGraphNodeId tied_node = 0;
  double t = 0.0;
  int coil = 0;  ///< the coil its signature measures (index in the sequence's coil list)
  Eigen::Vector3d signature_enu = Eigen::Vector3d::Zero();
  double radius_m = 0.0;
  uint32_t num_members = 0;
};

/// Builds the sparse representation of one group of members (time order): the median member,
/// the mean of the members within smoothing_half_window of it, and the radius (horizontal, in
/// the VIO frame of the members): walking outwards from the median member by distance, the
/// largest distance before the first member whose signature differs from the representative by
/// more than max_relative_variation of its magnitude, at most the distance to the nearer end
/// (first or last member) of the group; clamped to [min_radius_m, max_radius_m].
/// Returns nothing for fewer than min_members members.
std::optional<MagneticSubmapDraft> summariseMagneticGroup(const std::vector<PlacedSignature>& members,
                                                          const MagneticSubmapOptions& options);

/// Incremental grouping of one coil's signatures (PoseGraphManager keeps one builder per coil).
/// Feed placed signatures in time order; a signature that does not fit the open group (other
/// coil, other session, time gap, relative variation from the group's first member
/// beyond the threshold, or the group is full) closes it and starts the next group.
class MagneticSubmapBuilder {
 public:
  /// Throws std::invalid_argument for invalid options.
  explicit MagneticSubmapBuilder(const MagneticSubmapOptions& options);

  /// Adds a signature. Signatures weaker than min_amplitude_tesla close the open group and are
  /// dropped. Returns the submap closed by this call, if any.
  std::optional<MagneticSubmapDraft> add(const PlacedSignature& signature);
  /// An invalid window, a dropout or an unplaceable signature: closes the open group.
  std::optional<MagneticSubmapDraft> breakGroup();

  size_t openMembers() const { return open_.size(); }
  const MagneticSubmapOptions& options() const { return options_; }

 private:
  MagneticSubmapOptions options_;
  std::vector<PlacedSignature> open_;
};

}  // namespace vims
