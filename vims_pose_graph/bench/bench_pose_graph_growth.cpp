/// vims_pose_graph_bench: cost of the online pose-graph optimisation as the graph grows, on a
/// synthetic tank-like trajectory (docs/pose_graph.md, "Cost of the optimisation").
///
/// Laps of a 16 m x 8 m rectangle at 0.08 m per keyframe (tank750: 130 m over 1641 keyframes),
/// a VIO with a random-walk and constant yaw drift and a 1 % scale error, a geomagnetic yaw
/// factor on every keyframe (3 deg noise) and a loop every `--loop-every` keyframes from the
/// second lap on, to the same place on a random earlier lap. The graph is optimised as the
/// PoseGraphManager schedules it: after every loop, every 10 keyframes, and once at the end
/// (full), with the manager's tolerances. `--full` optimises the whole graph every time (no
/// partial solves; `--ftol` also uses function_tolerance online, i.e. no early stop). Prints per-kind
/// solve times (wall and thread CPU) and the final and online position errors against the truth.

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <iomanip>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "vims_common/timing.h"
#include "vims_pose_graph/angles.h"
#include "vims_pose_graph/pose_graph.h"

using namespace vims;

namespace {

constexpr double kDeg = M_PI / 180.0;

Eigen::Isometry3d pose(double yaw, const Eigen::Vector3d& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = rotationZ(yaw);
  T.translation() = p;
  return T;
}

/// Position and heading on the rectangle (counter-clockwise from the origin) at arc length s.
Eigen::Isometry3d rectanglePose(double s) {
  const double a = 16.0, b = 8.0, lap = 2 * (a + b);
  s = std::fmod(s, lap);
  if (s < a) return pose(0.0, Eigen::Vector3d(s, 0, -2));
  if (s < a + b) return pose(M_PI / 2, Eigen::Vector3d(a, s - a, -2));
  if (s < 2 * a + b) return pose(M_PI, Eigen::Vector3d(a - (s - a - b), b, -2));
  return pose(-M_PI / 2, Eigen::Vector3d(0, b - (s - 2 * a - b), -2));
}

struct Timing {
  std::vector<double> wall_ms, cpu_ms;
  int iterations = 0;
  void add(double wall, double cpu, int it) {
    wall_ms.push_back(wall);
    cpu_ms.push_back(cpu);
    iterations += it;
  }
};

}  // namespace

int main(int argc, char** argv) {
  size_t keyframes = 3600;
  int loop_every = 15;
  bool full = false, strict = false;
  unsigned seed = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--keyframes" && i + 1 < argc) {
      keyframes = std::stoul(argv[++i]);
    } else if (a == "--loop-every" && i + 1 < argc) {
      loop_every = std::stoi(argv[++i]);
    } else if (a == "--seed" && i + 1 < argc) {
      seed = static_cast<unsigned>(std::stoul(argv[++i]));
    } else if (a == "--full") {
      full = true;
    } else if (a == "--ftol") {
      strict = true;
    } else {
      std::cerr << "usage: vims_pose_graph_bench [--keyframes 3600] [--loop-every 15] [--seed 1] [--full] [--ftol]\n";
      return 2;
    }
  }
  const double step = 0.08, lap_keyframes = 48.0 / step;
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);

  // Truth and VIO.
  std::vector<Eigen::Isometry3d> truth, odom;
  double yaw_err = 0.0;
  Eigen::Isometry3d T_odom = rectanglePose(0.0);
  for (size_t k = 0; k < keyframes; ++k) {
    truth.push_back(rectanglePose(step * static_cast<double>(k)));
    if (k > 0) {
      const Eigen::Isometry3d rel = truth[k - 1].inverse() * truth[k];
      yaw_err += 0.002 * kDeg + 0.02 * kDeg * normal(rng);
      Eigen::Isometry3d noisy = rel;
      noisy.translation() *= 1.01;
      T_odom = T_odom * noisy * pose(0.02 * kDeg * normal(rng) + 0.002 * kDeg, Eigen::Vector3d::Zero());
    }
    odom.push_back(T_odom);
  }
  (void)yaw_err;

  PoseGraphOptions options;
  if (full) {
    options.loop_solve_from_earliest_node = false;
    options.window_keyframes = 0;
  }
  if (strict) options.online_function_tolerance = options.function_tolerance;
  PoseGraph4Dof graph(options, MagnetometerCalibration());
  const Eigen::Vector3d B_w(0.0, 25e-6, -43e-6);  // ENU, no declination
  Timing loop_t, periodic_t, final_t;
  size_t loops = 0, since_solve = 0;
  auto solve = [&](size_t first_free, LoopEdgeId first_new_loop, Timing* t, bool final_solve = false) {
    PoseGraphSnapshot s = graph.snapshot();
    if (!final_solve) s.options.function_tolerance = options.online_function_tolerance;
    s.first_free_node = first_free;
    s.first_new_loop_id = first_new_loop;
    const double cpu0 = threadCpuSeconds();
    const auto t0 = std::chrono::steady_clock::now();
    const PoseGraphSolution x = PoseGraph4Dof::solve(s);
    graph.applySolution(x);
    t->add(1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
           1e3 * (threadCpuSeconds() - cpu0), x.report.iterations);
    since_solve = 0;
  };
  std::uniform_int_distribution<int> pick;
  for (size_t k = 0; k < keyframes; ++k) {
    const PoseGraphNodeId id = graph.addNode(0.5 * static_cast<double>(k), odom[k]);
    if (k > 0) graph.addSequentialEdge(id - 1, id);
    const double heading_noise = 3.0 * kDeg * normal(rng);
    graph.addYawMeasurement(id, (truth[k].linear() * rotationZ(heading_noise)).transpose() * B_w);
    ++since_solve;
    const int lap = static_cast<int>(static_cast<double>(k) / lap_keyframes);
    if (lap >= 1 && k % static_cast<size_t>(loop_every) == 0) {
      // The same place on a random earlier lap, measured with 2 cm / 0.3 deg of noise.
      const int earlier = std::uniform_int_distribution<int>(0, lap - 1)(rng);
      const size_t match = k - static_cast<size_t>(std::lround((lap - earlier) * lap_keyframes));
      Eigen::Isometry3d rel = truth[match].inverse() * truth[k];
      rel.translation() += 0.02 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
      rel = rel * pose(0.3 * kDeg * normal(rng), Eigen::Vector3d::Zero());
      const LoopEdgeId l = graph.addLoopEdge(static_cast<PoseGraphNodeId>(match), id, rel);
      ++loops;
      // As SolveScheduler::planSolve after a loop that is not local (the bench does not model
      // local loop solves, PoseGraphOptions::loop_local_solve_max_sigmas).
      solve(options.loop_solve_from_earliest_node ? match : 0, l, &loop_t);
    } else if (since_solve >= 10) {
      // Periodic: the newest window_keyframes.
      const size_t n = graph.numNodes();
      const size_t w = static_cast<size_t>(options.window_keyframes);
      solve(w > 0 && n > w ? n - w : 0, static_cast<LoopEdgeId>(loops), &periodic_t);
    }
  }
  auto rmsError = [&]() {
    double sum = 0.0;
    for (size_t k = 0; k < keyframes; ++k)
      sum += (graph.node(static_cast<PoseGraphNodeId>(k)).p_w_b - truth[k].translation()).squaredNorm();
    return std::sqrt(sum / static_cast<double>(keyframes));
  };
  const double online_error = rmsError();
  solve(0, static_cast<LoopEdgeId>(loops), &final_t, true);
  const double final_error = rmsError();

  std::cout << std::fixed << std::setprecision(1) << keyframes << " keyframes, " << loops << " loops, "
            << (full ? "whole-graph solves" : "partial solves") << ", online function tolerance " << std::scientific
            << std::setprecision(0) << options.online_function_tolerance << std::fixed << "\n";
  auto row = [&](const char* name, const Timing& t) {
    double total = 0.0;
    for (double v : t.wall_ms) total += v;
    std::cout << "  " << name << ": " << t.wall_ms.size() << " solves, wall p50 " << percentile(t.wall_ms, 0.5)
              << " / p99 " << percentile(t.wall_ms, 0.99) << " / max " << percentile(t.wall_ms, 1.0) << " ms, CPU p50 "
              << percentile(t.cpu_ms, 0.5) << " / p99 " << percentile(t.cpu_ms, 0.99) << " / max "
              << percentile(t.cpu_ms, 1.0) << " ms, total " << std::setprecision(2) << 1e-3 * total << " s, "
              << t.iterations << " iterations\n"
              << std::setprecision(1);
  };
  row("loop", loop_t);
  row("periodic", periodic_t);
  row("final", final_t);
  std::cout << std::setprecision(4) << "  position RMS error: online " << online_error << " m, after the final solve "
            << final_error << " m\n";
  return 0;
}
