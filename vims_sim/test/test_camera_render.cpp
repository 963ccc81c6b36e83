// Camera model, seabed texture (determinism, tile-layout independence, bounded cache) and the
// renderer (photometry, geometry checked through KLT tracks, trackability, flat and terrain;
// ray-traced geometry against the analytic plane).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <thread>

#include "vims_common/camera_model.h"
#include "vims_sim/seabed_renderer.h"
#include "vims_sim/seabed_texture.h"
#include "vims_sim/sim_setup.h"
#include "vims_sim/terrain.h"
#include "vims_sim/trajectory.h"

using namespace vims::sim;

namespace {

vims::CameraCalibration testCalibration() {
  vims::CameraCalibration c;
  c.width = 640;
  c.height = 480;
  c.fx = 421.0;
  c.fy = 419.5;
  c.cx = 321.0;
  c.cy = 238.0;
  c.distortion = {-0.06, 0.009, 3e-4, -2e-4};
  return c;
}

/// Camera looking straight down from (x, y, altitude), image up = north.
Eigen::Isometry3d downwardCamera(double x, double y, double altitude) {
  Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  T_w_c.linear() = R;
  T_w_c.translation() = Eigen::Vector3d(x, y, altitude);
  return T_w_c;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

// The simulator renders with the one camera model of VIMS (vims_common/camera_model.h).
TEST(SimCamera, ProjectUnprojectRoundTrip) {
  const vims::CameraModel camera(testCalibration());
  double worst = 0.0;
  for (double v = 0; v < 480; v += 23.5) {
    for (double u = 0; u < 640; u += 31.25) {
      const std::optional<Eigen::Vector3d> ray = camera.unprojectPixel(Eigen::Vector2d(u, v));
      ASSERT_TRUE(ray.has_value());
      const std::optional<Eigen::Vector2d> back = camera.project(2.7 * *ray);
      ASSERT_TRUE(back.has_value());
      worst = std::max(worst, (*back - Eigen::Vector2d(u, v)).norm());
    }
  }
  EXPECT_LT(worst, 1e-9);
  EXPECT_FALSE(camera.project(Eigen::Vector3d(0, 0, -1)).has_value());
  // The principal point sees straight ahead.
  EXPECT_LT((*camera.unprojectPixel(Eigen::Vector2d(321.0, 238.0)) - Eigen::Vector3d(0, 0, 1)).norm(), 1e-12);
}

TEST(SeabedTexture, DeterministicPerWorldSeed) {
  SeabedTexture a(5), b(5), c(6);
  cv::Mat pa(300, 400, CV_8UC1), pb(300, 400, CV_8UC1), pc(300, 400, CV_8UC1);
  a.fillPatch(0, -700, 250, pa);
  b.fillPatch(0, -700, 250, pb);
  c.fillPatch(0, -700, 250, pc);
  EXPECT_EQ(cv::norm(pa, pb, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(pa, pc, cv::NORM_L1) / pa.total(), 5.0);
}

TEST(SeabedTexture, ContentDoesNotDependOnTheTileLayout) {
  // The texture is a function of world coordinates: tiles of another size hold the same texels
  // (no seams, and regenerated tiles are identical).
  SeabedTextureParams small_tiles;
  small_tiles.tile_texels = 256;
  SeabedTexture big(9), small(9, small_tiles);
  for (int level : {0, 2}) {
    cv::Mat a(260, 330, CV_8UC1), b(260, 330, CV_8UC1);
    const int64_t gx0 = -(512 >> level) - 100, gy0 = (512 >> level) - 130;  // straddles tile borders
    big.fillPatch(level, gx0, gy0, a);
    small.fillPatch(level, gx0, gy0, b);
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0) << "level " << level;
  }
}

TEST(SeabedTexture, CacheStaysBoundedAndRegeneratesIdentically) {
  SeabedTextureParams params;
  params.cache_tiles = 6;
  SeabedTexture texture(3, params);
  cv::Mat first(64, 64, CV_8UC1), again(64, 64, CV_8UC1);
  texture.fillPatch(0, 10, 10, first);
  for (int i = 0; i < 12; ++i) {
    cv::Mat patch(32, 32, CV_8UC1);
    texture.fillPatch(0, 512 * (i + 1), 0, patch);  // other tiles push the first one out
    EXPECT_LE(texture.tilesCached(), 6u);
  }
  texture.fillPatch(0, 10, 10, again);
  EXPECT_EQ(cv::norm(first, again, cv::NORM_INF), 0.0);
  EXPECT_EQ(texture.tilesGenerated(), 14u);
}

// A cache smaller than what one frame reads would evict, frame after frame, the tiles the next
// frame reads again: reserveTiles keeps a frame's tiles, and the renderer reserves twice them.
TEST(SeabedTexture, ReservedCapacityKeepsAWideViewsTiles) {
  SeabedTextureParams params;
  params.cache_tiles = 4;
  const SeabedTexture thrashing(3, params), reserved(3, params);
  cv::Mat patch(3 * 512 - 20, 3 * 512 - 20, CV_8UC1);
  EXPECT_EQ(reserved.tilesSpanned(0, 10, 10, patch.cols, patch.rows), 9u);
  EXPECT_EQ(reserved.tilesSpanned(1, 10, 10, 700, 10), 3u);  // level-1 tiles are 256 texels
  reserved.reserveTiles(9);
  for (int frame = 0; frame < 2; ++frame) {
    thrashing.fillPatch(0, 10, 10, patch);
    reserved.fillPatch(0, 10, 10, patch);
  }
  EXPECT_EQ(thrashing.tilesGenerated(), 18u);
  EXPECT_EQ(reserved.tilesGenerated(), 9u);
  EXPECT_EQ(reserved.tilesCached(), 9u);

  // The renderer reserves for its view: a wide camera high above the seabed rendered twice
  // generates its tiles once.
  auto texture = std::make_shared<SeabedTexture>(2, params);
  const SeabedRenderer renderer(testCalibration(), texture);
  renderer.render(downwardCamera(0.0, 1.0, 6.0), 1);
  const size_t first = texture->tilesGenerated();
  EXPECT_GT(first, 4u);
  renderer.render(downwardCamera(0.0, 1.0, 6.0), 1);
  EXPECT_EQ(texture->tilesGenerated(), first);
}

TEST(SeabedTexture, HasSparseAndDenseStretches) {
  const SeabedTexture texture(1);
  int sparse = 0, dense = 0, n = 0;
  for (double x = -40; x < 40; x += 0.5) {
    for (double y = -30; y < 30; y += 0.5) {
      const double d = texture.featureDensity(x, y);
      ASSERT_GE(d, 0.0);
      ASSERT_LE(d, 1.0);
      sparse += d < 0.15;
      dense += d > 0.85;
      ++n;
    }
  }
  EXPECT_GT(sparse, n / 20);
  EXPECT_GT(dense, n / 20);
}

TEST(SeabedTexture, AChangedSeabedDiffersOnItsFractionOfTheAreaOnly) {
  // A repeat mission's re-laid patches: about the asked fraction of the area, another seabed
  // there, and exactly the world's own seabed everywhere else.
  SeabedTextureParams changed_params;
  changed_params.change_fraction = 0.2;
  changed_params.change_seed = 9;
  const SeabedTexture world(5), changed(5, changed_params);
  int inside = 0, n = 0;
  for (double x = -40; x < 40; x += 0.25) {
    for (double y = -40; y < 40; y += 0.25) {
      inside += changed.changeWeight(x, y) > 0.5;
      ++n;
      ASSERT_EQ(world.changeWeight(x, y), 0.0);
    }
  }
  EXPECT_NEAR(static_cast<double>(inside) / n, 0.2, 0.06);
  cv::Mat a(512, 512, CV_8UC1), b(512, 512, CV_8UC1);
  int same_outside = 0, outside = 0, differ_inside = 0, fully_inside = 0;
  for (int64_t tile = -3; tile <= 3; ++tile) {
    world.fillPatch(0, tile * 512, 2 * 512, a);
    changed.fillPatch(0, tile * 512, 2 * 512, b);
    const double s = world.texelSize(0);
    for (int r = 0; r < 512; r += 4) {
      for (int c = 0; c < 512; c += 4) {
        const double w = changed.changeWeight((tile * 512 + c + 0.5) * s, (2 * 512 + r + 0.5) * s);
        if (w == 0.0) {
          ++outside;
          same_outside += a.at<uint8_t>(r, c) == b.at<uint8_t>(r, c);
        } else if (w == 1.0) {
          ++fully_inside;
          differ_inside += a.at<uint8_t>(r, c) != b.at<uint8_t>(r, c);
        }
      }
    }
  }
  ASSERT_GT(outside, 1000);
  ASSERT_GT(fully_inside, 200);
  EXPECT_EQ(same_outside, outside);
  EXPECT_GT(differ_inside, 0.8 * fully_inside);
}

TEST(SeabedRenderer, DarkerWhenHigherAndBlackWhenTheLampFails) {
  auto texture = std::make_shared<SeabedTexture>(2);
  const SeabedRenderer renderer(testCalibration(), texture);
  double mean2 = 0, mean5 = 0;
  for (double x : {0.0, 7.0, -9.0}) {
    mean2 += cv::mean(renderer.render(downwardCamera(x, 1.0, 2.0), 1))[0];
    mean5 += cv::mean(renderer.render(downwardCamera(x, 1.0, 5.0), 1))[0];
  }
  mean2 /= 3;
  mean5 /= 3;
  EXPECT_GT(mean2, 100.0);
  EXPECT_LT(mean2, 200.0);
  EXPECT_LT(mean5, 0.6 * mean2);
  EXPECT_GT(mean5, 25.0);
  // Lamp failure: only sensor noise.
  const cv::Mat black = renderer.render(downwardCamera(0, 1, 3), 5, false);
  cv::Scalar mean, stddev;
  cv::meanStdDev(black, mean, stddev);
  EXPECT_LT(mean[0], 3.0);
  EXPECT_GT(stddev[0], 0.1);  // noise, not a constant
  EXPECT_EQ(black.type(), CV_8UC1);
  EXPECT_EQ(black.cols, 640);
  EXPECT_EQ(black.rows, 480);
}

TEST(SeabedRenderer, MurkyWaterAndADimLampLoseContrast) {
  // vims_sim --turbidity and --lamp-power: the seabed's contrast (the spread of the image) falls
  // with murkier water and a dimmer lamp.
  auto texture = std::make_shared<SeabedTexture>(2);
  UnderwaterOptics murky, dim;
  murky.attenuation *= 4.0;
  murky.backscatter_range /= 4.0;
  dim.lamp_power = 0.3;
  const SeabedRenderer clear_renderer(testCalibration(), texture), murky_renderer(testCalibration(), texture, murky),
      dim_renderer(testCalibration(), texture, dim);
  auto meanAndSpread = [&](const SeabedRenderer& renderer) {
    cv::Scalar mean, stddev;
    cv::meanStdDev(renderer.render(downwardCamera(3.0, 1.0, 4.0), 1), mean, stddev);
    return std::make_pair(mean[0], stddev[0]);
  };
  const auto clear = meanAndSpread(clear_renderer), turbid = meanAndSpread(murky_renderer),
             dimmed = meanAndSpread(dim_renderer);
  // Measured at 4 m (grey levels, after the camera's response curve): clear mean 59.7, spread
  // 17.3; turbidity 4: 37.3, 10.6; lamp at 0.3: 24.5, 9.7.
  EXPECT_LT(turbid.second, 0.8 * clear.second);
  EXPECT_LT(dimmed.second, 0.75 * clear.second);
  EXPECT_LT(dimmed.first, 0.6 * clear.first);
  EXPECT_GT(turbid.first, 0.3 * clear.first);
}

TEST(SeabedRenderer, DeterministicAndThreadSafe) {
  auto texture = std::make_shared<SeabedTexture>(4);
  const SeabedRenderer renderer(testCalibration(), texture);
  const Eigen::Isometry3d pose = downwardCamera(2.0, -3.0, 3.0);
  cv::Mat a, b;
  std::thread ta([&] { a = renderer.render(pose, 77); });
  std::thread tb([&] { b = renderer.render(pose, 77); });
  ta.join();
  tb.join();
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  const cv::Mat c = renderer.render(pose, 78);  // other sensor noise
  EXPECT_GT(cv::norm(a, c, cv::NORM_L1), 0.0);
  EXPECT_LT(cv::norm(a, c, cv::NORM_L1) / a.total(), 4.0);
}

namespace {

struct TrackingStats {
  std::vector<double> corner_counts, survival, geometry_error;
  std::vector<double> flat_geometry_error;  ///< over terrain: the error if the seabed were taken as z = 0
};

/// Renders 25 frames at two places along the sequence's trajectory with the real rig, tracks
/// Shi-Tomasi corners with KLT (forward-backward checked) and compares the tracked positions
/// with the true geometry: the seabed point seen in frame k (the pixel's ray intersected with
/// the true seabed: the plane z = 0, or the terrain) projected into frame k+1 with the true poses.
TrackingStats trackAlongTheTrajectory(const SimSetup& setup, const std::vector<double>& start_times) {
  const auto& camera_calibration = setup.config.camera;
  const vims::CameraModel camera(camera_calibration);
  auto texture = std::make_shared<SeabedTexture>(setup.options.worldSeed());
  const bool flat = setup.terrain->isFlat();
  const SeabedRenderer renderer(camera_calibration, texture, UnderwaterOptics(), flat ? nullptr : setup.terrain);
  const Eigen::Isometry3d& T_b_c = camera_calibration.T_b_c;
  TrackingStats stats;
  for (double t_start : start_times) {
    cv::Mat previous;
    Eigen::Isometry3d previous_T_w_c = Eigen::Isometry3d::Identity();
    for (int k = 0; k < 25; ++k) {
      const double t = t_start + 0.1 * k;
      const Eigen::Isometry3d T_w_c = setup.trajectory.pose(t) * T_b_c;
      const cv::Mat image = renderer.render(T_w_c, 1000 + k);
      std::vector<cv::Point2f> corners;
      cv::goodFeaturesToTrack(image, corners, 300, 0.01, 15);
      stats.corner_counts.push_back(corners.size());
      if (!previous.empty()) {
        std::vector<cv::Point2f> p0, p1, p0_back;
        cv::goodFeaturesToTrack(previous, p0, 300, 0.01, 15);
        std::vector<uchar> status, status_back;
        std::vector<float> error;
        cv::calcOpticalFlowPyrLK(previous, image, p0, p1, status, error, cv::Size(21, 21), 3);
        cv::calcOpticalFlowPyrLK(image, previous, p1, p0_back, status_back, error, cv::Size(21, 21), 3);
        int survived = 0;
        std::vector<double> errors, flat_errors;
        for (size_t i = 0; i < p0.size(); ++i) {
          if (!status[i] || !status_back[i] || cv::norm(p0[i] - p0_back[i]) > 0.5) continue;
          ++survived;
          // Where the seabed point seen at p0 must appear in the new image.
          const Eigen::Vector3d ray_w =
              previous_T_w_c.linear() * *camera.unprojectPixel(Eigen::Vector2d(p0[i].x, p0[i].y));
          const Eigen::Vector3d origin = previous_T_w_c.translation();
          Eigen::Vector3d ground = origin - origin.z() / ray_w.z() * ray_w;
          if (!flat) {
            if (const auto predicted = camera.project(T_w_c.inverse() * ground)) {
              flat_errors.push_back((*predicted - Eigen::Vector2d(p1[i].x, p1[i].y)).norm());
            }
            TerrainHit hit;
            if (!setup.terrain->intersectRay(origin, ray_w, 100.0, &hit)) continue;
            ground = hit.point;
          }
          const auto predicted = camera.project(T_w_c.inverse() * ground);
          if (!predicted) continue;
          errors.push_back((*predicted - Eigen::Vector2d(p1[i].x, p1[i].y)).norm());
        }
        stats.survival.push_back(p0.empty() ? 0.0 : survived / static_cast<double>(p0.size()));
        if (!errors.empty()) stats.geometry_error.push_back(median(errors));
        if (!flat_errors.empty()) stats.flat_geometry_error.push_back(median(flat_errors));
      }
      previous = image;
      previous_T_w_c = T_w_c;
    }
  }
  std::cout << "corners per frame: median " << median(stats.corner_counts) << ", min "
            << *std::min_element(stats.corner_counts.begin(), stats.corner_counts.end())
            << "; KLT forward-backward survival: median " << median(stats.survival)
            << "; KLT vs true geometry: median error " << median(stats.geometry_error) << " px";
  if (!stats.flat_geometry_error.empty()) std::cout << " (" << median(stats.flat_geometry_error) << " px taking z = 0)";
  std::cout << "\n";
  return stats;
}

SimOptions trackingOptions() {
  SimOptions options;
  options.scenario = Scenario::kTank;
  options.duration = 200.0;
  options.seed = 21;
  options.out_dir = "unused";
  return options;
}

}  // namespace

// A short sequence along the tank trajectory with the real rig: enough Shi-Tomasi corners, KLT
// tracks that survive the forward-backward check, and tracked positions that agree with the
// true geometry (seabed point of the first frame projected into the second with the true poses).
TEST(SeabedRenderer, FramesAreTrackableAndGeometricallyConsistent) {
  const TrackingStats stats = trackAlongTheTrajectory(buildSimSetup(trackingOptions()), {40.0, 150.0});
  const auto& corner_counts = stats.corner_counts;
  const auto& survival = stats.survival;
  const auto& geometry_error = stats.geometry_error;
  EXPECT_GE(median(corner_counts), 100.0);
  EXPECT_GE(*std::min_element(corner_counts.begin(), corner_counts.end()), 40.0);
  EXPECT_GE(median(survival), 0.8);
  ASSERT_FALSE(geometry_error.empty());
  EXPECT_LT(median(geometry_error), 0.3);  // pixels
}

// The same over rough terrain (2 deg, relief, 10 cm roughness, rocks): the true depth of each
// tracked point is the terrain's, and the images stay trackable.
TEST(SeabedRenderer, TerrainFramesAreTrackableAndGeometricallyConsistent) {
  SimOptions options = trackingOptions();
  options.terrain.preset = "rough";
  const SimSetup setup = buildSimSetup(options);
  ASSERT_FALSE(setup.terrain->isFlat());
  const TrackingStats stats = trackAlongTheTrajectory(setup, {40.0, 150.0});
  EXPECT_GE(median(stats.corner_counts), 100.0);
  EXPECT_GE(median(stats.survival), 0.8);
  ASSERT_FALSE(stats.geometry_error.empty());
  EXPECT_LT(median(stats.geometry_error), 0.26);  // pixels; measured 0.13, as on the flat seabed
  // The terrain's depth matters even between consecutive frames (3 cm apart): the depth of the
  // plane z = 0 predicts the tracks worse (measured 0.18 px against 0.13 px).
  EXPECT_GT(median(stats.flat_geometry_error), 1.2 * median(stats.geometry_error));
}

// On a plane tilted by a known slope the ray-traced geometry is the analytic ray-plane
// intersection: range, incidence on the plane's normal and the ground point.
TEST(SeabedRenderer, TiltedPlaneGeometryIsTheAnalyticIntersection) {
  TerrainParams params;
  params.slope_deg = 12.0;
  params.slope_azimuth_deg = 200.0;
  params.seed = 1;
  auto terrain = std::make_shared<const SeabedTerrain>(params);
  auto texture = std::make_shared<SeabedTexture>(2);
  const vims::CameraCalibration calibration = testCalibration();
  const vims::CameraModel camera(calibration);
  const SeabedRenderer tilted(calibration, texture, UnderwaterOptics(), terrain);
  const SeabedRenderer flat(calibration, texture);
  Eigen::Isometry3d T_w_c = downwardCamera(2.0, -3.0, 3.0);
  T_w_c.linear() = T_w_c.linear() * Eigen::AngleAxisd(0.15, Eigen::Vector3d(1, 0.5, 0).normalized()).toRotationMatrix();
  // z = -tan(slope) u . (x, y): the plane n . p = 0 with n = (tan(slope) u, 1).
  const double s = std::tan(12.0 * M_PI / 180.0), az = 200.0 * M_PI / 180.0;
  const Eigen::Vector3d n_tilted = Eigen::Vector3d(s * std::sin(az), s * std::cos(az), 1.0).normalized();
  const Eigen::Vector3d n_flat(0, 0, 1);
  for (const auto& [renderer, normal] : {std::make_pair(&tilted, n_tilted), std::make_pair(&flat, n_flat)}) {
    const SeabedRenderer::ViewGeometry g = renderer->viewGeometry(T_w_c);
    double worst_range = 0.0, worst_cos = 0.0, worst_ground = 0.0;
    int hits = 0;
    for (int v = 0; v < calibration.height; v += 7) {
      for (int u = 0; u < calibration.width; u += 7) {
        const Eigen::Vector3d ray_c = *camera.unprojectPixel(Eigen::Vector2d(u, v));
        const Eigen::Vector3d d = T_w_c.linear() * ray_c, o = T_w_c.translation();
        const double t = -normal.dot(o) / normal.dot(d);
        ASSERT_GT(t, 0.0);
        ASSERT_EQ(g.hit.at<uint8_t>(v, u), 1);
        ++hits;
        worst_range = std::max(worst_range, std::abs(g.range.at<float>(v, u) - t * ray_c.norm()) / (t * ray_c.norm()));
        worst_cos = std::max(worst_cos, std::abs(g.cos_incidence.at<float>(v, u) + normal.dot(d.normalized())));
        worst_ground = std::max(
            worst_ground,
            (Eigen::Vector2d(g.ground_x.at<float>(v, u), g.ground_y.at<float>(v, u)) - t * d.head<2>()).norm());
      }
    }
    std::cout << (renderer == &tilted ? "tilted" : "flat") << " plane, " << hits
              << " pixels: worst relative range error " << worst_range << ", cos(incidence) " << worst_cos
              << ", ground point " << worst_ground << " m\n";
    EXPECT_LT(worst_range, 4e-7);     // measured 1.9e-7 (float storage)
    EXPECT_LT(worst_cos, 5e-7);       // measured 2.4e-7
    EXPECT_LT(worst_ground, 1.1e-6);  // measured 5.3e-7
  }
}

// Over rough terrain every hit of the renderer lies on the surface (range stored in float).
TEST(SeabedRenderer, TerrainHitsLieOnTheSurface) {
  SimOptions options = trackingOptions();
  options.terrain.preset = "rough";
  const SimSetup setup = buildSimSetup(options);
  const vims::CameraModel camera(setup.config.camera);
  const SeabedRenderer renderer(setup.config.camera, std::make_shared<SeabedTexture>(1), UnderwaterOptics(),
                                setup.terrain);
  double worst = 0.0;
  int hits = 0;
  for (double t : {30.0, 95.0, 170.0}) {
    const Eigen::Isometry3d T_w_c = setup.trajectory.pose(t) * setup.config.camera.T_b_c;
    const SeabedRenderer::ViewGeometry g = renderer.viewGeometry(T_w_c);
    for (int v = 0; v < g.hit.rows; v += 3) {
      for (int u = 0; u < g.hit.cols; u += 3) {
        ASSERT_EQ(g.hit.at<uint8_t>(v, u), 1);
        const Eigen::Vector3d ray_c = *camera.unprojectPixel(Eigen::Vector2d(u, v));
        const Eigen::Vector3d p = T_w_c * (ray_c * (g.range.at<float>(v, u) / ray_c.norm()));
        worst = std::max(worst, std::abs(p.z() - setup.terrain->height(p.x(), p.y())));
        ++hits;
      }
    }
  }
  std::cout << hits << " pixels over rough terrain: worst |z - h| at the hit " << worst << " m\n";
  EXPECT_LT(worst, 1e-6);  // measured 4.4e-7 (float range)
}

// Any mounting: a camera tilted 45 deg forward and turned 90 deg about its optical axis (the
// steepest the simulator takes) renders frames whose KLT tracks agree with the true geometry as
// the downward camera's do: the rays, the mounting and the seabed's far field are consistent.
TEST(SeabedRenderer, ATiltedAndTurnedCameraIsGeometricallyConsistent) {
  SimOptions options = trackingOptions();
  options.camera_tilt_deg = 45.0;
  options.camera_roll_deg = 90.0;
  const TrackingStats stats = trackAlongTheTrajectory(buildSimSetup(options), {150.0});
  EXPECT_GE(median(stats.corner_counts), 100.0);
  EXPECT_GE(median(stats.survival), 0.7);
  ASSERT_FALSE(stats.geometry_error.empty());
  EXPECT_LT(median(stats.geometry_error), 0.35);  // pixels; measured 0.19
}
