// Writes the generated part of the fuzz seed corpora (the rest are the repository's real files, copied by
// scripts/fuzz.sh): one encoded message of every type (lcm_decode), a small run log of every channel
// (lcm_log), the same messages as UDP datagrams (lcm_wire), and an exoskeleton states CSV (states_csv).
// Usage: fuzz_make_seeds OUT_DIR
#include <lcm/eventlog.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/state_columns.hpp"

namespace fs = std::filesystem;
using namespace exoid;

namespace {

template <class Msg>
std::vector<uint8_t> encode(const Msg& msg) {
  std::vector<uint8_t> b(static_cast<size_t>(msg.getEncodedSize()));
  msg.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

void writeFile(const fs::path& path, const std::vector<uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

void put(std::vector<uint8_t>& v, uint32_t x, int bytes) {
  for (int s = 8 * (bytes - 1); s >= 0; s -= 8) v.push_back(static_cast<uint8_t>(x >> s));
}

// One message per channel for tick k, as (channel, bytes).
std::vector<std::pair<std::string, std::vector<uint8_t>>> messages(const Model& model, int64_t k) {
  const int nj = model.njoints;
  const auto& joints = model.joint_names;
  std::vector<std::pair<std::string, std::vector<uint8_t>>> out;

  RobotStateSample s;
  s.tick = k;
  s.utime = 1000 * k;
  s.q = Eigen::VectorXd::LinSpaced(nj, -0.3, 0.4);
  s.tau = Eigen::VectorXd::LinSpaced(nj, 1.0, 2.0);
  s.has_tau = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(nj, true);
  s.has_tau[0] = false;
  s.tau[0] = 0.0;
  s.imu_orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()));
  s.imu_gyro << 0.01, -0.02, 0.03;
  s.imu_accel << 0.1, 0.0, 9.81;
  exoid_lcm::robot_state_t sm;
  toLcm(s, joints, sm);
  out.emplace_back(channels::kState, encode(sm));

  for (int p = 0; p < 2; ++p) {
    ForcePlateSample f;
    f.plate = p;
    f.tick = k;
    f.utime = 1000 * k;
    f.force << 1.0, -2.0, -300.0;
    f.moment << 0.5, 0.25, -0.1;
    f.cop << 0.01, -0.02, 0.0;
    f.plate_position << 0.03, p == 0 ? -0.11 : 0.11, 0.0;
    exoid_lcm::force_plate_t fm;
    toLcm(f, fm);
    out.emplace_back(p == 0 ? channels::kPlateRight : channels::kPlateLeft, encode(fm));
  }

  GroundTruthSample t;
  t.tick = k;
  t.utime = 1000 * k;
  t.base_position << 0.0, 0.0, 0.9;
  t.q = s.q;
  t.v = Eigen::VectorXd::Constant(nj, 0.1);
  t.a = Eigen::VectorXd::Constant(nj, -0.2);
  t.tau_applied = s.tau;
  for (int p = 0; p < 2; ++p) {
    t.foot_force[p] = Eigen::Vector3d(0.0, 0.0, 300.0);
    t.foot_moment[p] = Eigen::Vector3d(p ? 30.0 : -30.0, 1.0, 0.0);
  }
  exoid_lcm::ground_truth_t tm;
  toLcm(t, joints, tm);
  out.emplace_back(channels::kTruth, encode(tm));

  JointCommandSample c;
  c.tick = k + 1;
  c.source_tick = k;
  c.utime = 1000 * k;
  c.tau = Eigen::VectorXd::LinSpaced(nj, -5.0, 5.0);
  c.tau_ff = Eigen::VectorXd::Zero(nj);
  exoid_lcm::joint_command_t cm;
  toLcm(c, joints, cm);
  out.emplace_back(channels::kCommand, encode(cm));

  ControllerStatusSample st;
  st.tick = k;
  st.utime = 1000 * k;
  st.qp_status = QpStatus::Solved;
  st.qp_iterations = 3;
  st.move_index = 0;
  exoid_lcm::controller_status_t stm;
  toLcm(st, stm);
  out.emplace_back(channels::kControllerStatus, encode(stm));

  EstimatorOutputSample e;
  e.tick = k;
  e.utime = 1000 * k;
  e.valid = true;
  e.samples_used = 100;
  e.params = model.phi;
  e.param_stddev = Eigen::VectorXd::Constant(model.nparams(), 0.01);
  e.consistent = true;
  e.excitation = 0.5;
  e.effective_samples = 100.0;
  const Eigen::Index nb = static_cast<Eigen::Index>(computeBaseParameters(model).independent.size());
  e.base_params = Eigen::VectorXd::Constant(nb, 0.1);
  e.base_stddev = Eigen::VectorXd::Constant(nb, 0.01);
  e.tau_correction = Eigen::VectorXd::Zero(model.nv);
  e.tau_correction_stddev = Eigen::VectorXd::Zero(model.nv);
  e.residual_rms = Eigen::VectorXd::Constant(model.nv, 0.1);
  exoid_lcm::estimator_output_t em;
  toLcm(e, model.paramNames(), model.coordinateNames(), em);
  out.emplace_back(channels::kEstimate, encode(em));
  return out;
}

int typeIndex(const std::string& channel) {  // the selector byte of fuzz_lcm_decode
  if (channel == channels::kState) return 0;
  if (channel == channels::kPlateRight || channel == channels::kPlateLeft) return 1;
  if (channel == channels::kCommand) return 2;
  if (channel == channels::kControllerStatus) return 3;
  if (channel == channels::kEstimate) return 4;
  return 5;  // kTruth
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_make_seeds OUT_DIR\n");
    return 2;
  }
  const fs::path out = argv[1];
  Model model;
  std::string error;
  if (!buildModelFromUrdfFile(EXOID_CONFIG_DIR "/exo.urdf", true, model, &error)) {
    std::fprintf(stderr, "fuzz_make_seeds: %s\n", error.c_str());
    return 1;
  }
  for (const char* d : {"lcm_decode", "lcm_log", "lcm_wire", "states_csv"}) fs::create_directories(out / d);

  // lcm_decode: the selector byte, then one message.
  for (const auto& [channel, bytes] : messages(model, 7)) {
    std::vector<uint8_t> seed{static_cast<uint8_t>(typeIndex(channel))};
    seed.insert(seed.end(), bytes.begin(), bytes.end());
    writeFile(out / "lcm_decode" / (channel + ".bin"), seed);
  }

  // lcm_log: three ticks of every channel, written by LCM's own event-log writer.
  const std::string log_path = (out / "lcm_log" / "run.lcmlog").string();
  lcm_eventlog_t* log = lcm_eventlog_create(log_path.c_str(), "w");
  if (!log) return std::fprintf(stderr, "fuzz_make_seeds: cannot write %s\n", log_path.c_str()), 1;
  for (int64_t k = 0; k < 3; ++k) {
    for (auto& [channel, bytes] : messages(model, k)) {
      lcm_eventlog_event_t e{};
      e.timestamp = 1000 * k;
      e.channellen = static_cast<int32_t>(channel.size());
      e.channel = channel.data();
      e.datalen = static_cast<int32_t>(bytes.size());
      e.data = bytes.data();
      if (lcm_eventlog_write_event(log, &e) != 0) return 1;
    }
  }
  lcm_eventlog_destroy(log);

  // lcm_wire: records [sender][length][datagram]; small messages whole, the estimate in 3 fragments.
  std::vector<uint8_t> wire;
  uint32_t seq = 0;
  for (const auto& [channel, bytes] : messages(model, 1)) {
    std::vector<std::vector<uint8_t>> datagrams;
    if (channel != channels::kEstimate) {
      std::vector<uint8_t> d;
      put(d, 0x4c433032, 4);  // "LC02"
      put(d, seq, 4);
      d.insert(d.end(), channel.begin(), channel.end());
      d.push_back(0);
      d.insert(d.end(), bytes.begin(), bytes.end());
      datagrams.push_back(d);
    } else {
      const size_t chunk = bytes.size() / 3 + 1;
      for (uint32_t i = 0; i < 3; ++i) {
        std::vector<uint8_t> d;
        put(d, 0x4c433033, 4);  // "LC03"
        put(d, seq, 4);
        put(d, static_cast<uint32_t>(bytes.size()), 4);
        put(d, static_cast<uint32_t>(i * chunk), 4);
        put(d, i, 2);
        put(d, 3, 2);
        if (i == 0) d.insert(d.end(), channel.begin(), channel.end()), d.push_back(0);
        const size_t end = std::min(bytes.size(), (i + 1) * chunk);
        d.insert(d.end(), bytes.begin() + i * chunk, bytes.begin() + end);
        datagrams.push_back(d);
      }
    }
    for (const auto& d : datagrams) {
      wire.push_back(1);
      put(wire, static_cast<uint32_t>(d.size()), 2);
      wire.insert(wire.end(), d.begin(), d.end());
    }
    ++seq;
  }
  writeFile(out / "lcm_wire" / "run.bin", wire);

  // states_csv: the exoskeleton's columns (floating base), two samples.
  std::ofstream csv(out / "states_csv" / "exo_states.csv");
  csv << "t";
  for (const std::string& name : tools::StateColumns::names(model)) csv << ',' << name;
  csv << '\n';
  for (int k = 0; k < 2; ++k) {
    State state = State::zero(model);
    state.q.setLinSpaced(-0.2 * k, 0.3);
    state.v.setConstant(0.1 * k);
    state.a.setConstant(-0.5);
    state.base_orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.05 * k, Eigen::Vector3d::UnitX()));
    state.base_acceleration << 0.0, 0.1, 0.2;
    std::vector<double> row;
    tools::StateColumns::write(model, state, row);
    csv << 0.001 * k;
    for (double v : row) csv << ',' << v;
    csv << '\n';
  }
  if (!csv) return std::fprintf(stderr, "fuzz_make_seeds: cannot write the states CSV\n"), 1;
  std::printf("fuzz_make_seeds: seeds in %s\n", out.c_str());
  return 0;
}
