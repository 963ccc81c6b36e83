/// Magnetic submaps on a synthetic dipole field: grouping, sparse representation, radius.

#include <gtest/gtest.h>

#include <cmath>

#include "vims_common/magnetic_signature.h"
#include "vims_pose_graph/loop_detector.h"
#include "vims_pose_graph/magnetic_submap.h"

namespace vims {
namespace {

/// Peak field of a vertical magnetic dipole (the seabed coil) at p: mu0/(4 pi r^3) (3 r^(m.r^) - m).
Eigen::Vector3d dipoleField(const Eigen::Vector3d& coil, double moment, const Eigen::Vector3d& p) {
  const Eigen::Vector3d r = p - coil;
  const double d = r.norm();
  const Eigen::Vector3d u = r / d;
  const Eigen::Vector3d m(0.0, 0.0, moment);
  return 1e-7 / (d * d * d) * (3.0 * u * m.dot(u) - m);
}

/// Signatures every 0.4 s along a straight pass at 3 m altitude over (and past) the coil, at 0.3 m/s.
std::vector<PlacedSignature> pass(const Eigen::Vector3d& coil, double x0, double x1) {
  std::vector<PlacedSignature> out;
  const double speed = 0.3, hop = 0.4;
  for (double t = 0.0; x0 + speed * t <= x1; t += hop) {
    PlacedSignature s;
    s.t = t;
    s.session = 0;
    s.p_odom = Eigen::Vector3d(x0 + speed * t, 0.5, 3.0);
    s.signature_enu = dipoleField(coil, 270.0, s.p_odom);
    s.nearest_node = static_cast<PoseGraphNodeId>(std::lround(t));  // a keyframe every second
    out.push_back(s);
  }
  return out;
}

std::vector<MagneticSubmapDraft> build(const std::vector<PlacedSignature>& signatures, const MagneticSubmapOptions& o) {
  MagneticSubmapBuilder builder(o);
  std::vector<MagneticSubmapDraft> out;
  for (const PlacedSignature& s : signatures)
    if (auto d = builder.add(s)) out.push_back(*d);
  if (auto d = builder.breakGroup()) out.push_back(*d);
  return out;
}

TEST(MagneticSubmaps, RadiusBoundsTheVariationOfTheTrueField) {
  const Eigen::Vector3d coil(0.0, 0.0, 0.0);
  const MagneticSubmapOptions o;
  const std::vector<MagneticSubmapDraft> submaps = build(pass(coil, -12.0, 12.0), o);
  ASSERT_GT(submaps.size(), 5u);
  for (const MagneticSubmapDraft& d : submaps) {
    // Sparse representation: the smoothed signature is close to the true field at the median point.
    const Eigen::Vector3d truth = dipoleField(coil, 270.0, d.p_odom);
    EXPECT_LT((d.signature_enu - truth).norm(), 0.05 * truth.norm()) << "submap at x=" << d.p_odom.x();
    EXPECT_GE(d.radius_m, o.min_radius_m);
    EXPECT_LE(d.radius_m, o.max_radius_m);
    EXPECT_GE(d.num_members, static_cast<uint32_t>(o.min_members));
    // Within the radius (along the path, where the members were) the true field varies less
    // than the threshold, unless the radius was raised to its minimum.
    if (d.radius_m > o.min_radius_m) {
      for (double dx = -d.radius_m; dx <= d.radius_m; dx += 0.02) {
        const Eigen::Vector3d p = d.p_odom + Eigen::Vector3d(dx, 0.0, 0.0);
        EXPECT_LE((dipoleField(coil, 270.0, p) - d.signature_enu).norm(),
                  (o.max_relative_variation + 0.02) * d.signature_enu.norm())
            << "submap at x=" << d.p_odom.x() << ", offset " << dx;
      }
    }
  }
}

TEST(MagneticSubmaps, SubmapsGrowAwayFromTheCoilAndCoverThePass) {
  const Eigen::Vector3d coil(0.0, 0.0, 0.0);
  MagneticSubmapOptions o;
  o.min_radius_m = 0.0;  // the radius the field gives
  const std::vector<PlacedSignature> signatures = pass(coil, -14.0, 14.0);
  const std::vector<MagneticSubmapDraft> submaps = build(signatures, o);
  ASSERT_GT(submaps.size(), 10u);
  double near_radius = 0.0, far_radius = 0.0;
  int near_count = 0, far_count = 0;
  for (const MagneticSubmapDraft& d : submaps) {
    if (std::abs(d.p_odom.x()) < 4.0) {
      near_radius += d.radius_m;
      ++near_count;
    } else if (std::abs(d.p_odom.x()) > 9.0) {
      far_radius += d.radius_m;
      ++far_count;
    }
  }
  ASSERT_GT(near_count, 0);
  ASSERT_GT(far_count, 0);
  // The dipole field changes fastest near the coil: small submaps there, large ones far away.
  EXPECT_LT(near_radius / near_count, 0.5 * far_radius / far_count);
  // Sparse: far fewer submaps than signatures, and every mapped place is clustered by some
  // submap (radius + margin), so the magnetic stage leaves no hole along the track.
  EXPECT_LT(submaps.size(), signatures.size() / 3);
  for (const PlacedSignature& s : signatures) {
    bool covered = false;
    for (const MagneticSubmapDraft& d : submaps)
      if ((s.p_odom - d.p_odom).head<2>().norm() <= d.radius_m + o.cluster_margin_m) covered = true;
    EXPECT_TRUE(covered) << "no submap near x=" << s.p_odom.x();
  }
  // Tied to the keyframe nearest in time to the median member.
  for (const MagneticSubmapDraft& d : submaps) EXPECT_EQ(d.tied_node, static_cast<PoseGraphNodeId>(std::lround(d.t)));
}

TEST(MagneticSubmaps, WeakSignaturesGapsAndSessionsCloseGroups) {
  const Eigen::Vector3d coil(0.0, 0.0, 0.0);
  MagneticSubmapOptions o;
  o.max_relative_variation = 10.0;  // the field alone would never close a group
  o.max_members = 1000;
  std::vector<PlacedSignature> s = pass(coil, -2.0, 2.0);
  ASSERT_GT(s.size(), 20u);
  // A time gap in the middle closes the group: two submaps.
  for (size_t i = s.size() / 2; i < s.size(); ++i) s[i].t += 5.0;
  EXPECT_EQ(build(s, o).size(), 2u);
  // A new session too.
  std::vector<PlacedSignature> s2 = pass(coil, -2.0, 2.0);
  for (size_t i = s2.size() / 2; i < s2.size(); ++i) s2[i].session = 1;
  EXPECT_EQ(build(s2, o).size(), 2u);
  // Weak signatures (below min_amplitude_tesla) are not mapped.
  o.min_amplitude_tesla = 1e-3;  // the largest allowed, far above a coil signature (uT)
  EXPECT_TRUE(build(s, o).empty());
  // Too few members: nothing.
  MagneticSubmapOptions few = o;
  few.min_amplitude_tesla = 0.0;
  few.min_members = 100;
  EXPECT_TRUE(build(pass(coil, -1.0, 1.0), few).empty());
}

TEST(MagneticSubmaps, SignOfTheSignatureDoesNotSplitOrBiasSubmaps) {
  // The extractor's sign follows the dominant axis, so a pass where two components swap
  // dominance flips the whole vector. Flipping alternate members must not change the submaps.
  const Eigen::Vector3d coil(0.0, 0.0, 0.0);
  const MagneticSubmapOptions o;
  const std::vector<PlacedSignature> signatures = pass(coil, -12.0, 12.0);
  std::vector<PlacedSignature> flipped = signatures;
  for (size_t i = 0; i < flipped.size(); i += 2) flipped[i].signature_enu = -flipped[i].signature_enu;
  const std::vector<MagneticSubmapDraft> a = build(signatures, o);
  const std::vector<MagneticSubmapDraft> b = build(flipped, o);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].num_members, b[i].num_members);
    EXPECT_NEAR(a[i].radius_m, b[i].radius_m, 1e-12);
    EXPECT_NEAR(signatureDistance(a[i].signature_enu, b[i].signature_enu), 0.0, 1e-6 * a[i].signature_enu.norm());
  }
  EXPECT_DOUBLE_EQ(signatureDistance(Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(-1, -2, -3)), 0.0);
  EXPECT_DOUBLE_EQ(signatureDistance(Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0)), std::sqrt(2.0));
  EXPECT_TRUE(alignedSignature(Eigen::Vector3d(-1, 0, 0), Eigen::Vector3d(2, 1, 0)).isApprox(Eigen::Vector3d(1, 0, 0)));
}

TEST(MagneticSubmaps, SummarySmoothsAroundTheMedianAndWalksTheRadiusOutwards) {
  MagneticSubmapOptions o;
  o.smoothing_half_window = 1;
  o.min_radius_m = 0.0;
  o.max_relative_variation = 0.1;
  std::vector<PlacedSignature> m(5);
  const double x[5] = {0.0, 1.0, 2.0, 3.0, 4.0};
  const double v[5] = {1.0, 1.0, 1.3, 1.0, 2.0};  // x-component; the smoothed median is (1+1.3+1)/3 = 1.1
  for (int i = 0; i < 5; ++i) {
    m[static_cast<size_t>(i)].t = i;
    m[static_cast<size_t>(i)].p_odom = Eigen::Vector3d(x[i], 0.0, 7.0 * i);  // height must not count
    m[static_cast<size_t>(i)].signature_enu = Eigen::Vector3d(v[i], 0.0, 0.0);
    m[static_cast<size_t>(i)].nearest_node = static_cast<PoseGraphNodeId>(10 + i);
  }
  const std::optional<MagneticSubmapDraft> d = summariseMagneticGroup(m, o);
  ASSERT_TRUE(d);
  EXPECT_NEAR(d->signature_enu.x(), 1.1, 1e-12);
  EXPECT_EQ(d->tied_node, 12u);
  EXPECT_DOUBLE_EQ(d->t, 2.0);
  // |1.3 - 1.1| = 0.2 > 0.11 at distance 0: the walk stops at once -> radius 0.
  EXPECT_DOUBLE_EQ(d->radius_m, 0.0);
  m[2].signature_enu.x() = 1.1;  // smoothed median now (1 + 1.1 + 1) / 3 = 1.0333; members 1, 3 within 0.10333
  const std::optional<MagneticSubmapDraft> d2 = summariseMagneticGroup(m, o);
  ASSERT_TRUE(d2);
  // distances 0 (ok), 1 (x=1 and x=3: ok), 2 (x=0: ok; x=4: 2.0 differs) -> stops at 2 after x=0
  EXPECT_DOUBLE_EQ(d2->radius_m, 2.0);
}

TEST(MagneticSubmaps, AGroupHoldsOneCoil) {
  MagneticSubmapOptions o;
  o.min_members = 1;
  MagneticSubmapBuilder builder(o);
  PlacedSignature a;
  a.t = 0.0;
  a.coil = 0;
  a.signature_enu = Eigen::Vector3d(1e-7, 0.0, 2e-7);
  EXPECT_FALSE(builder.add(a));
  PlacedSignature b = a;  // the same field, measured of another coil
  b.t = 0.4;
  b.coil = 1;
  const std::optional<MagneticSubmapDraft> closed = builder.add(b);
  ASSERT_TRUE(closed);
  EXPECT_EQ(closed->coil, 0);
  EXPECT_EQ(closed->num_members, 1u);
  const std::optional<MagneticSubmapDraft> last = builder.breakGroup();
  ASSERT_TRUE(last);
  EXPECT_EQ(last->coil, 1);
}

std::vector<MagneticSubmap> coilSubmaps(const std::vector<std::pair<int, Eigen::Vector3d>>& coil_signatures) {
  std::vector<MagneticSubmap> out;
  for (const auto& [coil, signature] : coil_signatures) {
    MagneticSubmap s;
    s.id = static_cast<uint32_t>(out.size());
    s.tied_node = s.id;
    s.coil = coil;
    s.signature_enu = signature;
    out.push_back(s);
  }
  return out;
}

TEST(MagneticStage, ComparesEachSubmapWithTheQuerysSignatureOfItsCoil) {
  const Eigen::Vector3d s(2e-7, -1e-7, 3e-7);
  const Eigen::Vector3d far(-5e-6, 5e-6, 1e-6);
  const std::vector<MagneticSubmap> submaps = coilSubmaps({{0, s}, {1, s}, {1, far}});
  const LoopDetectorOptions options;
  auto all = [](const MagneticSubmap&) { return true; };
  std::optional<MagneticStageMatch> nearest;

  std::vector<MagneticStageMatch> m = magneticStageMatches({{1, s}}, submaps, options, all, &nearest);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].submap, 1u);
  ASSERT_TRUE(nearest);
  EXPECT_EQ(nearest->submap, 1u);

  m = magneticStageMatches({{0, s}}, submaps, options, all, &nearest);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].submap, 0u);

  // A coil no submap measured: nothing passes and nothing is the nearest.
  EXPECT_TRUE(magneticStageMatches({{2, s}}, submaps, options, all, &nearest).empty());
  EXPECT_FALSE(nearest);

  // Far from coil 1's submaps and coil 0 unheard: nothing passes; the nearest is reported.
  EXPECT_TRUE(magneticStageMatches({{1, 0.5 * far + 0.5 * s}}, submaps, options, all, &nearest).empty());
  ASSERT_TRUE(nearest);

  // Both coils heard: both places are candidates; the filter still applies.
  m = magneticStageMatches({{0, s}, {1, s}}, submaps, options, all);
  EXPECT_EQ(m.size(), 2u);
  m = magneticStageMatches({{0, s}, {1, s}}, submaps, options, [](const MagneticSubmap& x) { return x.coil == 1; });
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].submap, 1u);
}

TEST(MagneticStage, KeepsTheNearestCandidatesOfEachCoil) {
  const Eigen::Vector3d s(2e-7, -1e-7, 3e-7);
  const Eigen::Vector3d weak(1e-8, 0.0, 2e-8);
  // Coil 0 strong (its distances in tesla are large), coil 1 weak: a cut over both coils
  // together would keep coil 1's submaps only.
  const std::vector<MagneticSubmap> submaps =
      coilSubmaps({{0, 1.05 * s}, {0, 1.1 * s}, {0, 1.15 * s}, {1, weak}, {1, 1.01 * weak}});
  LoopDetectorOptions options;
  options.mag_max_candidates = 2;
  const std::vector<MagneticStageMatch> m =
      magneticStageMatches({{0, s}, {1, weak}}, submaps, options, [](const MagneticSubmap&) { return true; });
  ASSERT_EQ(m.size(), 4u);
  std::vector<uint32_t> ids;
  for (const MagneticStageMatch& x : m) ids.push_back(x.submap);
  EXPECT_EQ(ids, (std::vector<uint32_t>{3, 4, 0, 1}));  // nearest first over both coils
}

}  // namespace
}  // namespace vims
