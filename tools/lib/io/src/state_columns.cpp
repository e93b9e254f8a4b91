#include "exoid/tools/state_columns.hpp"

#include <cmath>
#include <sstream>

#include "exoid/sample_checks.hpp"

namespace exoid::tools {

namespace {
const char* const kQuat[4] = {"base_qw", "base_qx", "base_qy", "base_qz"};
const char* const kW[3] = {"base_wx", "base_wy", "base_wz"};
const char* const kV[3] = {"base_vx", "base_vy", "base_vz"};
const char* const kDW[3] = {"base_dwx", "base_dwy", "base_dwz"};
const char* const kA[3] = {"base_ax", "base_ay", "base_az"};
const char* const kP[3] = {"base_px", "base_py", "base_pz"};
}  // namespace

std::vector<std::string> StateColumns::names(const Model& model, bool with_base_position) {
  std::vector<std::string> out;
  for (const char* prefix : {"q_", "v_", "a_"})
    for (const std::string& j : model.joint_names) out.push_back(prefix + j);
  if (model.floating_base) {
    for (auto group : {kQuat}) for (int i = 0; i < 4; ++i) out.push_back(group[i]);
    for (auto group : {kW, kV, kDW, kA}) for (int i = 0; i < 3; ++i) out.push_back(group[i]);
    if (with_base_position) for (int i = 0; i < 3; ++i) out.push_back(kP[i]);
  }
  return out;
}

bool StateColumns::bind(const Model& model, const CsvTable& table, std::string* error) {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  // Every q_/v_/a_ column must name a joint of the model; every base_ column must be a known one.
  for (const std::string& h : table.header) {
    for (const char* prefix : {"q_", "v_", "a_"}) {
      if (h.rfind(prefix, 0) == 0 && model.jointIndex(h.substr(2)) < 0)
        return fail("column '" + h + "': the model has no joint '" + h.substr(2) + "'");
    }
    if (h.rfind("base_", 0) == 0) {
      bool known = false;
      for (auto group : {kW, kV, kDW, kA, kP}) for (int i = 0; i < 3; ++i) known |= h == group[i];
      for (int i = 0; i < 4; ++i) known |= h == kQuat[i];
      if (!known) return fail("column '" + h + "': unknown base column");
    }
  }
  auto need = [&](const std::string& name, int& index) {
    index = table.column(name);
    return index >= 0 || fail("missing column '" + name + "'");
  };
  floating_ = model.floating_base;
  q_.assign(model.njoints, -1);
  v_.assign(model.njoints, -1);
  a_.assign(model.njoints, -1);
  for (int j = 0; j < model.njoints; ++j) {
    if (!need("q_" + model.joint_names[j], q_[j]) || !need("v_" + model.joint_names[j], v_[j]) ||
        !need("a_" + model.joint_names[j], a_[j]))
      return false;
  }
  if (floating_) {
    for (int i = 0; i < 4; ++i) if (!need(kQuat[i], quat_[i])) return false;
    for (int i = 0; i < 3; ++i)
      if (!need(kW[i], w_[i]) || !need(kDW[i], dw_[i]) || !need(kA[i], acc_[i])) return false;
    // Optional: neither enters K (classical accelerations make the dynamics independent of them), and the
    // robot measures neither (sensor exports leave them out).
    for (int i = 0; i < 3; ++i) v_base_[i] = table.column(kV[i]), pos_[i] = table.column(kP[i]);
  }
  header_ = table.header;
  used_.clear();
  for (const std::vector<int>* g : {&q_, &v_, &a_}) used_.insert(used_.end(), g->begin(), g->end());
  if (floating_) {
    used_.insert(used_.end(), quat_, quat_ + 4);
    for (const int* g : {w_, v_base_, dw_, acc_, pos_})
      for (int i = 0; i < 3; ++i)
        if (g[i] >= 0) used_.push_back(g[i]);
  }
  return true;
}

bool StateColumns::read(const std::vector<double>& row, State& s, std::string* error) const {
  // The columns read, within the gate's range (the ignored ones are not judged).
  for (const int c : used_) {
    if (withinSampleRange(&row[static_cast<size_t>(c)], 1)) continue;
    if (error) {
      std::ostringstream o;
      o << "column " << c + 1 << " '" << header_[static_cast<size_t>(c)] << "': " << row[static_cast<size_t>(c)]
        << " is beyond the " << kMaxSampleMagnitude << " a state value can take";
      *error = o.str();
    }
    return false;
  }
  for (size_t j = 0; j < q_.size(); ++j) {
    s.q[j] = row[q_[j]];
    s.v[j] = row[v_[j]];
    s.a[j] = row[a_[j]];
  }
  if (!floating_) return true;
  Eigen::Quaterniond q(row[quat_[0]], row[quat_[1]], row[quat_[2]], row[quat_[3]]);
  if (std::abs(q.norm() - 1.0) > 1e-3) {
    if (error) *error = "base quaternion (base_qw, base_qx, base_qy, base_qz) is not unit length (norm " + std::to_string(q.norm()) + ")";
    return false;
  }
  s.base_orientation = q.normalized();
  for (int i = 0; i < 3; ++i) {
    s.base_omega[i] = row[w_[i]];
    s.base_velocity[i] = v_base_[i] >= 0 ? row[v_base_[i]] : 0.0;
    s.base_domega[i] = row[dw_[i]];
    s.base_acceleration[i] = row[acc_[i]];
    s.base_position[i] = pos_[i] >= 0 ? row[pos_[i]] : 0.0;
  }
  return true;
}

void StateColumns::write(const Model& model, const State& s, std::vector<double>& out, bool with_base_position) {
  for (int j = 0; j < model.njoints; ++j) out.push_back(s.q[j]);
  for (int j = 0; j < model.njoints; ++j) out.push_back(s.v[j]);
  for (int j = 0; j < model.njoints; ++j) out.push_back(s.a[j]);
  if (!model.floating_base) return;
  out.insert(out.end(), {s.base_orientation.w(), s.base_orientation.x(), s.base_orientation.y(), s.base_orientation.z()});
  for (const Eigen::Vector3d* v : {&s.base_omega, &s.base_velocity, &s.base_domega, &s.base_acceleration})
    out.insert(out.end(), {v->x(), v->y(), v->z()});
  if (with_base_position) out.insert(out.end(), {s.base_position.x(), s.base_position.y(), s.base_position.z()});
}

}  // namespace exoid::tools
