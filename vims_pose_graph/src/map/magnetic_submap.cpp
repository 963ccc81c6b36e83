#include "vims_pose_graph/magnetic_submap.h"

#include <algorithm>
#include <numeric>

#include "vims_common/magnetic_signature.h"

namespace vims {

std::optional<MagneticSubmapDraft> summariseMagneticGroup(const std::vector<PlacedSignature>& members,
                                                          const MagneticSubmapOptions& options) {
  if (members.empty() || members.size() < static_cast<size_t>(options.min_members)) return std::nullopt;
  const size_t n = members.size();
  const size_t median = n / 2;
  // Sparse representation: the signature smoothed over the members around the median one (the
  // windows overlap, so this is a short moving average along the path).
  const size_t h = static_cast<size_t>(options.smoothing_half_window);
  const size_t first = median >= h ? median - h : 0;
  const size_t last = std::min(n - 1, median + h);
  // Members' signs are aligned to the median one before averaging (see signatureDistance).
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (size_t i = first; i <= last; ++i)
    sum += alignedSignature(members[i].signature_enu, members[median].signature_enu);
  const Eigen::Vector3d signature = sum / static_cast<double>(last - first + 1);

  // Radius: grow a disc around the median member (horizontal distance: the seabed the camera
  // sees, and where the vehicle revisits, is a horizontal place) until the first member whose
  // signature differs from the representative by more than the threshold.
  const Eigen::Vector3d& centre = members[median].p_odom;
  std::vector<double> distance(n);
  for (size_t i = 0; i < n; ++i) distance[i] = (members[i].p_odom - centre).head<2>().norm();
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return distance[a] < distance[b]; });
  const double tolerance = options.max_relative_variation * signature.norm();
  double radius = 0.0;
  for (size_t i : order) {
    if (signatureDistance(members[i].signature_enu, signature) > tolerance) break;
    radius = distance[i];
  }
  // The members only sample the field along the path: beyond the nearer end of the group
  // nothing is known, so the disc does not reach past it (matters when the speed varied and
  // the median member is off-centre).
  radius = std::min(radius, std::min(distance.front(), distance.back()));

  MagneticSubmapDraft d;
  d.tied_node = members[median].nearest_node;
  d.t = members[median].t;
  d.coil = members[median].coil;
  d.session = members[median].session;
  d.signature_enu = signature;
  d.p_odom = centre;
  d.radius_m = std::clamp(radius, options.min_radius_m, options.max_radius_m);
  d.num_members = static_cast<uint32_t>(n);
  return d;
}

MagneticSubmapBuilder::MagneticSubmapBuilder(const MagneticSubmapOptions& options) : options_(options) {
  options_.validate();
}

std::optional<MagneticSubmapDraft> MagneticSubmapBuilder::breakGroup() {
  std::optional<MagneticSubmapDraft> closed = summariseMagneticGroup(open_, options_);
  open_.clear();
  return closed;
}

std::optional<MagneticSubmapDraft> MagneticSubmapBuilder::add(const PlacedSignature& s) {
  if (!s.signature_enu.allFinite() || !s.p_odom.allFinite() || s.signature_enu.norm() < options_.min_amplitude_tesla)
    return breakGroup();
  if (!open_.empty()) {
    const PlacedSignature& reference = open_.front();
    const bool fits = s.coil == reference.coil && s.session == reference.session &&
                      s.t - open_.back().t <= options_.max_time_gap_s && s.t >= open_.back().t &&
                      signatureDistance(s.signature_enu, reference.signature_enu) <=
                          options_.max_relative_variation * reference.signature_enu.norm() &&
                      open_.size() < static_cast<size_t>(options_.max_members);
    if (!fits) {
      std::optional<MagneticSubmapDraft> closed = summariseMagneticGroup(open_, options_);
      open_.clear();
      open_.push_back(s);
      return closed;
    }
  }
  open_.push_back(s);
  return std::nullopt;
}

}  // namespace vims
