// Peer benchmark: Pinocchio (C++) kinematics on a 7-DoF Franka Panda.
//
// Built and run by benches/peers/run_pinocchio.sh. Usage:
//   pinocchio_kinematics [URDF] [FRAME] [--samples N] [--configs N] [--seed S]
// (pass "" for URDF to keep the compiled-in default: example-robot-data's panda.urdf;
//  FRAME defaults to panda_hand, falling back to the last frame if absent)
//
// Loads URDF, locks panda_finger_joint1/2 (if present) at their neutral value (0)
// with buildReducedModel, then times, over a fixed seeded set of random
// configurations within the joint limits, the operations below. Methodology is
// criterion-like: warm up, then N samples, each sample = K full passes over the
// configuration set; per-call ns = sample time / (K * n_configs). Reports median,
// min and max per-call ns across samples as one JSON object on stdout.
//
//   fk_joints                   forwardKinematics(model, data, q)             (all joint placements oMi)
//   fk_all_frames               framesForwardKinematics(model, data, q)       (oMi + every frame oMf)
//   frame_jacobian_with_fk      computeFrameJacobian(model, data, q, f, LOCAL_WORLD_ALIGNED, J)
//                               (FK over the frame's support + oMf[f] + 6xnv LWA Jacobian, one call)
//   fk_frame_pose_and_jacobian  cheapest correct q -> (pose, 6x7 LWA Jacobian) of one frame. That is the
//                               call above (it sets data.oMf[f] itself); this entry additionally reads
//                               the pose and the full J back out, so it is the end-to-end cost.
//   fk_plus_frame_jacobian      the textbook idiom: computeJointJacobians(model, data, q) (full FK +
//                               all joint Jacobians) + updateFramePlacement + getFrameJacobian(LWA).
//
// Results are checked against each other (pose and Jacobian agree to 1e-12) before timing.

#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/joint-configuration.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/algorithm/model.hpp>
#include <pinocchio/multibody.hpp>
#include <pinocchio/parsers/urdf.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "peer_util.hpp"

#ifndef PIN_PEER_DEFAULT_URDF
#define PIN_PEER_DEFAULT_URDF ""
#endif

namespace
{
  using Clock = std::chrono::steady_clock;

  using peer::escape;
  using peer::json_escape;

  struct Stats
  {
    double median, min, max;
  };

  volatile double g_sink = 0.0;

  // op(i) runs one call on configuration i and returns a scalar folded into the checksum.
  template<typename Op>
  Stats run_bench(Op && op, std::size_t n_configs, int samples, double & checksum)
  {
    // Warm up for ~300 ms and estimate the per-pass time.
    double acc = 0.0;
    std::size_t passes = 0;
    const auto w0 = Clock::now();
    double warm_s = 0.0;
    do
    {
      for (std::size_t i = 0; i < n_configs; ++i)
        acc += op(i);
      ++passes;
      warm_s = std::chrono::duration<double>(Clock::now() - w0).count();
    } while (warm_s < 0.3);
    const double pass_s = warm_s / double(passes);
    // Each sample ~20 ms (at least one pass).
    const std::size_t k = std::max<std::size_t>(1, std::size_t(0.02 / pass_s));

    std::vector<double> per_call(samples);
    for (int s = 0; s < samples; ++s)
    {
      const auto t0 = Clock::now();
      for (std::size_t r = 0; r < k; ++r)
        for (std::size_t i = 0; i < n_configs; ++i)
          acc += op(i);
      const auto t1 = Clock::now();
      per_call[s] = std::chrono::duration<double, std::nano>(t1 - t0).count() / double(k * n_configs);
    }
    g_sink = g_sink + acc;
    // Deterministic checksum: one pass over the configuration set (independent of k/timing).
    for (std::size_t i = 0; i < n_configs; ++i)
      checksum += op(i);
    std::vector<double> sorted = per_call;
    std::sort(sorted.begin(), sorted.end());
    const std::size_t n = sorted.size();
    const double median =
      (n % 2) ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
    return {median, sorted.front(), sorted.back()};
  }

  [[noreturn]] void die(const std::string & msg)
  {
    std::cerr << "pinocchio_kinematics: " << msg << std::endl;
    std::exit(2);
  }
} // namespace

int main(int argc, char ** argv)
{
  std::string urdf = PIN_PEER_DEFAULT_URDF;
  std::string frame_name = "panda_hand";
  int samples = 50;
  std::size_t n_configs = 1000;
  unsigned long long seed = 42;

  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc)
        die("missing value after " + a);
      return argv[++i];
    };
    if (a == "--samples")
      samples = std::stoi(next());
    else if (a == "--configs")
      n_configs = std::stoul(next());
    else if (a == "--seed")
      seed = std::stoull(next());
    else if (a == "-h" || a == "--help")
    {
      std::cerr << "usage: " << argv[0]
                << " [URDF] [FRAME] [--samples N] [--configs N] [--seed S]\n";
      return 0;
    }
    else
      positional.push_back(a);
  }
  // An empty positional argument keeps the default.
  if (positional.size() > 0 && !positional[0].empty())
    urdf = positional[0];
  if (positional.size() > 1 && !positional[1].empty())
    frame_name = positional[1];
  if (positional.size() > 2)
    die("too many positional arguments");
  if (urdf.empty())
    die("no URDF given and no default compiled in");
  if (samples < 1 || n_configs < 1)
    die("--samples and --configs must be >= 1");

  // ---- model ------------------------------------------------------------------
  pinocchio::Model full;
  try
  {
    pinocchio::urdf::buildModel(urdf, full);
  }
  catch (const std::exception & e)
  {
    die("failed to load URDF '" + urdf + "': " + e.what());
  }

  std::vector<pinocchio::JointIndex> to_lock;
  std::vector<std::string> locked_names;
  for (const char * jn : {"panda_finger_joint1", "panda_finger_joint2"})
  {
    if (full.existJointName(jn))
    {
      to_lock.push_back(full.getJointId(jn));
      locked_names.push_back(jn);
    }
  }
  const Eigen::VectorXd q_lock = pinocchio::neutral(full); // 0 for the prismatic fingers
  pinocchio::Model model =
    to_lock.empty() ? full : pinocchio::buildReducedModel(full, to_lock, q_lock);
  pinocchio::Data data(model);

  if (model.nq != 7 || model.nv != 7)
    std::cerr << "warning: reduced model has nq=" << model.nq << " nv=" << model.nv
              << " (expected 7)" << std::endl;

  pinocchio::FrameIndex fid;
  if (model.existFrame(frame_name))
    fid = model.getFrameId(frame_name);
  else
  {
    fid = pinocchio::FrameIndex(model.nframes - 1);
    std::cerr << "warning: frame '" << frame_name << "' not found, using last frame '"
              << model.frames[fid].name << "'" << std::endl;
    frame_name = model.frames[fid].name;
  }

  // ---- configurations: uniform within position limits, seeded --------------------
  std::mt19937_64 rng(seed);
  std::vector<Eigen::VectorXd> qs(n_configs, Eigen::VectorXd(model.nq));
  for (auto & q : qs)
  {
    for (int j = 0; j < model.nq; ++j)
    {
      double lo = model.lowerPositionLimit[j], hi = model.upperPositionLimit[j];
      if (!std::isfinite(lo) || !std::isfinite(hi) || hi <= lo)
      {
        lo = -M_PI;
        hi = M_PI;
      }
      q[j] = std::uniform_real_distribution<double>(lo, hi)(rng);
    }
  }

  pinocchio::Data::Matrix6x J = pinocchio::Data::Matrix6x::Zero(6, model.nv);
  pinocchio::Data::Matrix6x J_ref = pinocchio::Data::Matrix6x::Zero(6, model.nv);
  const pinocchio::ReferenceFrame LWA = pinocchio::LOCAL_WORLD_ALIGNED;

  // ---- cross-check the variants agree -------------------------------------------
  {
    double max_pose_err = 0.0, max_jac_err = 0.0;
    pinocchio::Data d2(model);
    for (std::size_t i = 0; i < std::min<std::size_t>(n_configs, 100); ++i)
    {
      J.setZero();
      pinocchio::computeFrameJacobian(model, data, qs[i], fid, LWA, J);
      const pinocchio::SE3 pose = data.oMf[fid];

      pinocchio::framesForwardKinematics(model, d2, qs[i]);
      pinocchio::computeJointJacobians(model, d2, qs[i]);
      J_ref.setZero();
      pinocchio::getFrameJacobian(model, d2, fid, LWA, J_ref);

      max_pose_err = std::max(max_pose_err, (pose.toHomogeneousMatrix() - d2.oMf[fid].toHomogeneousMatrix()).cwiseAbs().maxCoeff());
      max_jac_err = std::max(max_jac_err, (J - J_ref).cwiseAbs().maxCoeff());
    }
    if (max_pose_err > 1e-12 || max_jac_err > 1e-12)
    {
      std::ostringstream os;
      os << "variants disagree: pose err " << max_pose_err << ", jacobian err " << max_jac_err;
      die(os.str());
    }
  }

  // ---- benchmarks ---------------------------------------------------------------
  double checksum = 0.0;
  const std::size_t last_joint = std::size_t(model.njoints - 1);

  struct Entry
  {
    const char * name;
    Stats s;
  };
  std::vector<Entry> results;

  results.push_back({"fk_joints", run_bench(
                                     [&](std::size_t i) {
                                       pinocchio::forwardKinematics(model, data, qs[i]);
                                       escape(data.oMi.data());
                                       return data.oMi[last_joint].translation()[0];
                                     },
                                     n_configs, samples, checksum)});

  results.push_back({"fk_all_frames", run_bench(
                                         [&](std::size_t i) {
                                           pinocchio::framesForwardKinematics(model, data, qs[i]);
                                           escape(data.oMf.data());
                                           return data.oMf[fid].translation()[0];
                                         },
                                         n_configs, samples, checksum)});

  results.push_back({"frame_jacobian_with_fk",
                     run_bench(
                       [&](std::size_t i) {
                         pinocchio::computeFrameJacobian(model, data, qs[i], fid, LWA, J);
                         escape(J.data());
                         escape(data.oMf.data());
                         return J(0, 0);
                       },
                       n_configs, samples, checksum)});

  results.push_back({"fk_frame_pose_and_jacobian",
                     run_bench(
                       [&](std::size_t i) {
                         pinocchio::computeFrameJacobian(model, data, qs[i], fid, LWA, J);
                         const pinocchio::SE3 & pose = data.oMf[fid];
                         escape(J.data());
                         escape(&pose);
                         return pose.translation().sum() + pose.rotation()(0, 0) + J.sum();
                       },
                       n_configs, samples, checksum)});

  results.push_back({"fk_plus_frame_jacobian",
                     run_bench(
                       [&](std::size_t i) {
                         pinocchio::computeJointJacobians(model, data, qs[i]);
                         const pinocchio::SE3 & pose =
                           pinocchio::updateFramePlacement(model, data, fid);
                         pinocchio::getFrameJacobian(model, data, fid, LWA, J);
                         escape(J.data());
                         escape(&pose);
                         return pose.translation()[0] + J(0, 0);
                       },
                       n_configs, samples, checksum)});

  // ---- report -------------------------------------------------------------------
#ifdef PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION
  const char * mode = "template-instantiation (algorithms run from libpinocchio_default.so)";
#else
  const char * mode = "header-only (algorithms inlined into this binary)";
#endif
  std::ostringstream out;
  out.precision(6);
  out << "{\"peer\": \"pinocchio-cpp\", \"version\": \"" << PINOCCHIO_VERSION << "\""
      << ", \"eigen\": \"" << EIGEN_WORLD_VERSION << "." << EIGEN_MAJOR_VERSION << "."
      << EIGEN_MINOR_VERSION << "\"" << ", \"compiler\": \"" << json_escape(__VERSION__) << "\""
      << ", \"mode\": \"" << mode << "\"" << ", \"urdf\": \"" << json_escape(urdf) << "\""
      << ", \"frame\": \"" << json_escape(frame_name) << "\"" << ", \"locked_joints\": [";
  for (std::size_t i = 0; i < locked_names.size(); ++i)
    out << (i ? ", " : "") << "\"" << locked_names[i] << "\"";
  out << "], \"nq\": " << model.nq << ", \"nv\": " << model.nv
      << ", \"njoints\": " << model.njoints << ", \"nframes\": " << model.nframes
      << ", \"n_configs\": " << n_configs << ", \"samples\": " << samples
      << ", \"seed\": " << seed << ", \"results_ns\": {";
  for (std::size_t i = 0; i < results.size(); ++i)
  {
    const auto & r = results[i];
    out << (i ? ", " : "") << "\"" << r.name << "\": {\"median\": " << r.s.median
        << ", \"min\": " << r.s.min << ", \"max\": " << r.s.max << "}";
  }
  out.precision(17);
  out << "}, \"checksum\": " << checksum << "}";
  std::cout << out.str() << std::endl;
  return 0;
}
