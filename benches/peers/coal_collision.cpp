// Peer benchmark: Pinocchio + coal (C++) collision checking and signed distances on a
// tandem collision scene (robot collision elements + primitive obstacles + pairs).
//
// Built and run by benches/peers/run_coal.sh, which converts the "collision scene exchange"
// JSON (see python_ref/coal_reference.py) into the line-based text file this program reads
// (there is no JSON library here). Usage:
//   coal_collision SCENE.txt [--seconds S]
//
// Scene text format: one string per line, numbers whitespace-separated:
//   tandem-coal-scene 1
//   <urdf path>
//   <n> then n package dirs, one per line
//   <n> then n active joint names (the order of each configuration)
//   <n> then n held joints, each as a name line and a value line
//   <n> then n robot element geometry names ("L_k": k-th <collision> of link L)
//   <n> then n obstacles: "<shape> a b c  tx ty tz  r00 r01 ... r22" where shape is
//       box (a b c = half extents) | sphere (a = radius) | cylinder | capsule (a = radius,
//       b = length along z, for the capsule of the cylindrical part)
//   <n> then n pairs "i j", indices into robot elements ++ obstacles
//   <n> <dof> then n configuration lines of dof values
//
// Timed, per call, over all configurations (each measurement repeated for ~S seconds, in
// ~20 ms batches; median and mean of the per-call time over batches, like
// pinocchio_kinematics.cpp):
//   collision_check            computeCollisions(model, data, gm, gd, q, stop_at_first=true)
//                              (FK + geometry placements + boolean narrow phase)
//   distance_all_pairs         computeDistances(model, data, gm, gd, q) (FK + placements +
//                              signed distance of every pair)
//   collision_check_no_fk      the same two, with forwardKinematics + updateGeometryPlacements
//   distance_all_pairs_no_fk   done untimed before each call: only the narrow phase is timed
//                              (per-call clock reads; their measured cost is subtracted).
//   fk_and_geometry_placements updateGeometryPlacements(model, data, gm, gd, q) alone (FK +
//                              oMg of every geometry): what the *_no_fk entries leave out.

#include <pinocchio/algorithm/geometry.hpp>
#include <pinocchio/algorithm/joint-configuration.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/collision/collision.hpp>
#include <pinocchio/collision/distance.hpp>
#include <pinocchio/multibody.hpp>
#include <pinocchio/parsers/urdf.hpp>

#include <coal/config.hh>
#include <coal/shape/geometric_shapes.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include "peer_util.hpp"

namespace
{
  using Clock = std::chrono::steady_clock;

  [[noreturn]] void die(const std::string & msg)
  {
    std::cerr << "coal_collision: " << msg << std::endl;
    std::exit(2);
  }

  using peer::escape;
  using peer::json_escape;

  // ---- scene file -----------------------------------------------------------------

  struct Obstacle
  {
    std::string shape;
    double a, b, c;
    pinocchio::SE3 placement;
  };

  struct Scene
  {
    std::string urdf;
    std::vector<std::string> package_dirs, joints, elements;
    std::vector<std::pair<std::string, double>> held;
    std::vector<Obstacle> obstacles;
    std::vector<std::pair<std::size_t, std::size_t>> pairs;
    std::vector<std::vector<double>> configurations;
  };

  struct Reader
  {
    std::ifstream in;
    std::size_t line_no = 0;

    std::string line()
    {
      std::string s;
      if (!std::getline(in, s))
        die("scene file ends early (line " + std::to_string(line_no + 1) + ")");
      ++line_no;
      return s;
    }
    // A line of numbers; exactly `n` of them unless n == 0 (then any count).
    std::vector<double> numbers(std::size_t n = 0)
    {
      std::istringstream is(line());
      std::vector<double> v;
      double x;
      while (is >> x)
        v.push_back(x);
      if (!is.eof() || (n && v.size() != n))
        die("bad number line " + std::to_string(line_no));
      return v;
    }
    std::size_t count()
    {
      return std::size_t(numbers(1)[0]);
    }
    std::vector<std::string> strings()
    {
      std::vector<std::string> v(count());
      for (auto & s : v)
        s = line();
      return v;
    }
  };

  Scene read_scene(const std::string & path)
  {
    Reader r;
    r.in.open(path);
    if (!r.in)
      die("cannot open scene file " + path);
    if (r.line() != "tandem-coal-scene 1")
      die(path + " is not a tandem-coal-scene 1 file");
    Scene s;
    s.urdf = r.line();
    s.package_dirs = r.strings();
    s.joints = r.strings();
    for (std::size_t i = 0, n = r.count(); i < n; ++i)
    {
      const std::string name = r.line();
      s.held.emplace_back(name, r.numbers(1)[0]);
    }
    s.elements = r.strings();
    for (std::size_t i = 0, n = r.count(); i < n; ++i)
    {
      std::istringstream is(r.line());
      Obstacle o;
      double v[12];
      is >> o.shape >> o.a >> o.b >> o.c;
      for (double & x : v)
        is >> x;
      if (!is)
        die("bad obstacle line " + std::to_string(r.line_no));
      Eigen::Matrix3d R;
      R << v[3], v[4], v[5], v[6], v[7], v[8], v[9], v[10], v[11];
      o.placement = pinocchio::SE3(R, Eigen::Vector3d(v[0], v[1], v[2]));
      s.obstacles.push_back(o);
    }
    for (std::size_t i = 0, n = r.count(); i < n; ++i)
    {
      const auto p = r.numbers(2);
      s.pairs.emplace_back(std::size_t(p[0]), std::size_t(p[1]));
    }
    const auto dims = r.numbers(2);
    if (std::size_t(dims[1]) != s.joints.size())
      die("configuration width differs from the number of joints");
    for (std::size_t i = 0; i < std::size_t(dims[0]); ++i)
      s.configurations.push_back(r.numbers(s.joints.size()));
    return s;
  }

  std::shared_ptr<coal::CollisionGeometry> make_shape(const Obstacle & o)
  {
    if (o.shape == "box") // coal::Box takes full side lengths
      return std::make_shared<coal::Box>(2 * o.a, 2 * o.b, 2 * o.c);
    if (o.shape == "sphere")
      return std::make_shared<coal::Sphere>(o.a);
    if (o.shape == "cylinder")
      return std::make_shared<coal::Cylinder>(o.a, o.b);
    if (o.shape == "capsule") // length of the cylindrical part
      return std::make_shared<coal::Capsule>(o.a, o.b);
    die("unknown obstacle shape " + o.shape);
  }

  // Writes one joint value into q (continuous joints are stored as (cos, sin)).
  void set_joint(const pinocchio::Model & model, Eigen::VectorXd & q, pinocchio::JointIndex j, double v)
  {
    const int iq = model.joints[j].idx_q(), nq = model.joints[j].nq();
    if (nq == 2)
    {
      q[iq] = std::cos(v);
      q[iq + 1] = std::sin(v);
    }
    else if (nq == 1)
      q[iq] = v;
    else
      die("joint " + model.names[j] + " has nq=" + std::to_string(nq) + " (only 1-dof joints)");
  }

  // ---- timing ----------------------------------------------------------------------

  struct Stats
  {
    double median, mean;
    std::size_t batches;
  };

  volatile double g_sink = 0.0;

  Stats summarize(std::vector<double> v)
  {
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    const double median = (n % 2) ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
    return {median, std::accumulate(v.begin(), v.end(), 0.0) / double(n), n};
  }

  // timed_pass() runs one pass over all configurations and returns the time it counts (ns):
  // wall time of the whole pass, or the sum of per-call narrow-phase times. Warm up ~0.3 s,
  // then batches of ~20 ms (k passes) until `seconds` have elapsed (at least 5 batches).
  template<typename Pass>
  Stats run_bench(Pass && timed_pass, std::size_t n_configs, double seconds)
  {
    const auto w0 = Clock::now();
    std::size_t passes = 0;
    double warm_s = 0.0;
    do
    {
      timed_pass();
      ++passes;
      warm_s = std::chrono::duration<double>(Clock::now() - w0).count();
    } while (warm_s < 0.3);
    const std::size_t k = std::max<std::size_t>(1, std::size_t(0.02 / (warm_s / double(passes))));

    std::vector<double> per_call;
    const auto t_start = Clock::now();
    do
    {
      double ns = 0.0;
      for (std::size_t r = 0; r < k; ++r)
        ns += timed_pass();
      per_call.push_back(ns / double(k * n_configs));
    } while (per_call.size() < 5
             || std::chrono::duration<double>(Clock::now() - t_start).count() < seconds);
    return summarize(per_call);
  }

  // Cost of the two clock reads bracketing a call (median over many back-to-back pairs).
  double timer_overhead_ns()
  {
    std::vector<double> v(200001);
    for (double & x : v)
    {
      const auto t0 = Clock::now();
      const auto t1 = Clock::now();
      x = std::chrono::duration<double, std::nano>(t1 - t0).count();
    }
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  }
} // namespace

int main(int argc, char ** argv)
{
  std::string scene_path;
  double seconds = 2.0;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    if (a == "--seconds" && i + 1 < argc)
      seconds = std::stod(argv[++i]);
    else if (a == "-h" || a == "--help")
    {
      std::cerr << "usage: " << argv[0] << " SCENE.txt [--seconds S]\n";
      return 0;
    }
    else if (scene_path.empty())
      scene_path = a;
    else
      die("unexpected argument " + a);
  }
  if (scene_path.empty())
    die("no scene file given");
  const Scene scene = read_scene(scene_path);
  const std::size_t n_configs = scene.configurations.size();
  if (n_configs == 0 || scene.pairs.empty())
    die("scene has no configurations or no pairs");

  // ---- model, geometry model, obstacles, pairs ---------------------------------------
  // Mimic joints become independent joints (buildModel's default); the scene gives their
  // values in `held`, like every joint not in `joints`.
  pinocchio::Model model;
  pinocchio::GeometryModel geom_model;
  try
  {
    pinocchio::urdf::buildModel(scene.urdf, model);
    pinocchio::urdf::buildGeom(
      model, scene.urdf, pinocchio::COLLISION, geom_model, scene.package_dirs);
  }
  catch (const std::exception & e)
  {
    die("failed to load URDF '" + scene.urdf + "': " + e.what());
  }

  std::vector<pinocchio::GeomIndex> ids;
  for (const auto & name : scene.elements)
  {
    if (!geom_model.existGeometryName(name))
      die("no collision geometry " + name + " in the URDF");
    ids.push_back(geom_model.getGeometryId(name));
  }
  for (std::size_t k = 0; k < scene.obstacles.size(); ++k)
  {
    const Obstacle & o = scene.obstacles[k];
    // Attached to the universe (joint 0, frame 0): a fixed world obstacle.
    ids.push_back(geom_model.addGeometryObject(pinocchio::GeometryObject(
      "obstacle_" + std::to_string(k) + "_" + o.shape, 0, 0, o.placement, make_shape(o))));
  }
  geom_model.removeAllCollisionPairs(); // only the requested pairs (the URDF adds none)
  for (const auto & p : scene.pairs)
  {
    if (p.first >= ids.size() || p.second >= ids.size() || p.first == p.second)
      die("bad pair index");
    const pinocchio::CollisionPair cp(ids[p.first], ids[p.second]);
    if (!geom_model.existCollisionPair(cp)) // (a, b) and (b, a) are the same pair
      geom_model.addCollisionPair(cp);
  }
  pinocchio::Data data(model);
  pinocchio::GeometryData geom_data(geom_model); // after the pairs: sizes its per-pair vectors

  // ---- configurations ----------------------------------------------------------------
  Eigen::VectorXd q_base = pinocchio::neutral(model);
  std::vector<bool> given(model.njoints, false);
  for (const auto & h : scene.held)
  {
    if (!model.existJointName(h.first))
      die("held joint " + h.first + " not in the model");
    const auto j = model.getJointId(h.first);
    set_joint(model, q_base, j, h.second);
    given[j] = true;
  }
  std::vector<pinocchio::JointIndex> active;
  for (const auto & name : scene.joints)
  {
    if (!model.existJointName(name))
      die("joint " + name + " not in the model");
    active.push_back(model.getJointId(name));
    given[active.back()] = true;
  }
  for (pinocchio::JointIndex j = 1; j < pinocchio::JointIndex(model.njoints); ++j)
    if (!given[j])
      die("scene gives no value for joint " + model.names[j]);
  std::vector<Eigen::VectorXd> qs(n_configs, q_base);
  for (std::size_t i = 0; i < n_configs; ++i)
    for (std::size_t k = 0; k < active.size(); ++k)
      set_joint(model, qs[i], active[k], scene.configurations[i][k]);

  // ---- reference results, cross-checked between the two queries ----------------------
  // distance_sum (over distinct pairs) is comparable with the sum of the distances
  // coal_reference.py writes (over requested pairs: the same when no pair is repeated).
  std::size_t colliding = 0, disagreements = 0;
  double distance_sum = 0.0;
  for (std::size_t i = 0; i < n_configs; ++i)
  {
    const bool hit = pinocchio::computeCollisions(model, data, geom_model, geom_data, qs[i], true);
    pinocchio::computeDistances(model, data, geom_model, geom_data, qs[i]);
    bool any_negative = false;
    for (const auto & r : geom_data.distanceResults)
    {
      distance_sum += r.min_distance;
      any_negative = any_negative || r.min_distance < 0;
    }
    colliding += hit;
    disagreements += (hit != any_negative);
  }

  // ---- benchmarks ----------------------------------------------------------------------
  // Each pass returns the ns it counts; results are folded into g_sink so nothing is elided.
  const double overhead = timer_overhead_ns();
  auto whole = [&](auto && call) {
    return [&, call]() {
      double acc = 0.0;
      const auto t0 = Clock::now();
      for (std::size_t i = 0; i < n_configs; ++i)
        acc += call(i);
      const auto t1 = Clock::now();
      g_sink = g_sink + acc;
      return std::chrono::duration<double, std::nano>(t1 - t0).count();
    };
  };
  auto narrow = [&](auto && call) {
    return [&, call]() {
      double acc = 0.0, ns = 0.0;
      for (std::size_t i = 0; i < n_configs; ++i)
      {
        pinocchio::updateGeometryPlacements(model, data, geom_model, geom_data, qs[i]);
        escape(geom_data.oMg.data());
        const auto t0 = Clock::now();
        acc += call(i);
        const auto t1 = Clock::now();
        ns += std::chrono::duration<double, std::nano>(t1 - t0).count() - overhead;
      }
      g_sink = g_sink + acc;
      return ns;
    };
  };
  auto collision_fk = [&](std::size_t i) {
    return double(pinocchio::computeCollisions(model, data, geom_model, geom_data, qs[i], true));
  };
  auto distance_fk = [&](std::size_t i) {
    return double(pinocchio::computeDistances(model, data, geom_model, geom_data, qs[i]))
           + geom_data.distanceResults[0].min_distance;
  };
  auto collision_only = [&](std::size_t) {
    return double(pinocchio::computeCollisions(geom_model, geom_data, true));
  };
  auto distance_only = [&](std::size_t) {
    return double(pinocchio::computeDistances(geom_model, geom_data))
           + geom_data.distanceResults[0].min_distance;
  };

  // What the *_no_fk entries leave out, on its own.
  auto placements = [&](std::size_t i) {
    pinocchio::updateGeometryPlacements(model, data, geom_model, geom_data, qs[i]);
    escape(geom_data.oMg.data());
    return geom_data.oMg.back().translation()[0];
  };

  struct Entry
  {
    const char * name;
    Stats s;
  };
  const std::vector<Entry> results = {
    {"fk_and_geometry_placements", run_bench(whole(placements), n_configs, seconds)},
    {"collision_check", run_bench(whole(collision_fk), n_configs, seconds)},
    {"distance_all_pairs", run_bench(whole(distance_fk), n_configs, seconds)},
    {"collision_check_no_fk", run_bench(narrow(collision_only), n_configs, seconds)},
    {"distance_all_pairs_no_fk", run_bench(narrow(distance_only), n_configs, seconds)},
  };

  // ---- report -----------------------------------------------------------------------
  std::ostringstream out;
  out.precision(6);
  out << "{\"peer\": \"pinocchio-coal-cpp\", \"coal_version\": \"" << COAL_VERSION << "\""
      << ", \"pinocchio_version\": \"" << PINOCCHIO_VERSION << "\""
      << ", \"compiler\": \"" << json_escape(__VERSION__) << "\""
      << ", \"urdf\": \"" << json_escape(scene.urdf) << "\""
      << ", \"configurations\": " << n_configs << ", \"pairs\": " << scene.pairs.size()
      << ", \"distinct_pairs\": " << geom_model.collisionPairs.size()
      << ", \"geometries\": " << geom_model.ngeoms
      << ", \"collision_fraction\": " << double(colliding) / double(n_configs)
      << ", \"collision_vs_distance_disagreements\": " << disagreements
      << ", \"seconds_per_measurement\": " << seconds
      << ", \"timer_overhead_ns\": " << overhead << ", \"results_ns\": {";
  for (std::size_t i = 0; i < results.size(); ++i)
  {
    const auto & r = results[i];
    out << (i ? ", " : "") << "\"" << r.name << "\": {\"median\": " << r.s.median
        << ", \"mean\": " << r.s.mean << ", \"batches\": " << r.s.batches << "}";
  }
  out.precision(17);
  out << "}, \"distance_sum\": " << distance_sum << "}";
  std::cout << out.str() << std::endl;
  return 0;
}
