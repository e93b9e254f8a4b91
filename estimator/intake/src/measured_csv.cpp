// Measured-data CSV -> measured samples (measured_input.hpp).
#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <vector>

#include "exoid/common/strict_number.hpp"
#include "exoid/intake/measured_input.hpp"

namespace exoid::intake {

namespace {

// Strict number: the whole cell, finite (common/strict_number.hpp).
bool parseCell(const std::string& cell, double& v) { return common::parseDouble(cell, v); }

void splitCells(const std::string& line, std::vector<std::string>& cells) {
  cells.clear();
  std::string cur;
  for (char ch : line) {
    if (ch == ',') {
      cells.push_back(cur);
      cur.clear();
    } else if (ch != ' ' && ch != '\t' && ch != '\r') {
      cur.push_back(ch);
    }
  }
  cells.push_back(cur);
}
}  // namespace

bool streamMeasuredCsv(const std::string& path, const Model& model, const int feet[2], bool skip_bad_rows,
                       const SampleSink& sink, InputStats& stats, std::string* error) {
  auto fail = [&](const std::string& m) {
    if (error) *error = path + ": " + m;
    return false;
  };
  // A row's place as an editor counts it (the header's line included) and a cell's column: number and name.
  auto at = [&](long line) { return path + ":" + std::to_string(line); };
  stats = InputStats();
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    if (error) *error = "cannot open '" + path + "'";
    return false;
  }
  std::string line;
  long line_no = 0;
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    ++line_no;
    if (line_no == 1 && line.size() >= 3 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);
    if (line.empty() || line[0] == '#' || line.find_first_not_of(" \t\r") == std::string::npos) continue;
    splitCells(line, header);
    break;
  }
  if (header.empty()) return fail("no header row");
  std::map<std::string, int> col;
  for (size_t i = 0; i < header.size(); ++i) {
    if (header[i].empty()) return fail("header column " + std::to_string(i + 1) + " has no name");
    if (!col.emplace(header[i], static_cast<int>(i)).second) return fail("column '" + header[i] + "' appears twice");
  }
  const int nj = model.njoints;
  auto need = [&](const std::string& name, int& index) {
    auto it = col.find(name);
    index = it == col.end() ? -1 : it->second;
    return index >= 0;
  };
  // Every column must be one exoid knows (a misnamed joint is an error, not a silently ignored column).
  std::set<std::string> known = {"t"};
  for (const std::string& j : model.joint_names)
    for (const char* pre : {"q_", "v_", "a_", "tau_"}) known.insert(pre + j);
  if (model.floating_base) {
    for (const char* c : {"qw", "qx", "qy", "qz", "wx", "wy", "wz", "ax", "ay", "az", "dwx", "dwy", "dwz", "px", "py", "pz", "vx", "vy", "vz"})
      known.insert(std::string("base_") + c);
    for (const char* side : {"right", "left"})
      for (const char* c : {"fx", "fy", "fz", "nx", "ny", "nz"}) known.insert(std::string("fp_") + side + "_" + c);
  }
  for (const std::string& h : header)
    if (!known.count(h)) return fail("unknown column '" + h + "' (not a " + (model.floating_base ? "floating" : "fixed") + "-base column of this model's joints; docs/identification.md)");
  int ct;
  if (!need("t", ct)) return fail("missing column 't'");
  std::vector<int> cq(nj), cv(nj), ca(nj), ctau(nj);
  int nv_cols = 0, na_cols = 0;
  for (int j = 0; j < nj; ++j) {
    const std::string& n = model.joint_names[j];
    if (!need("q_" + n, cq[j])) return fail("missing column 'q_" + n + "'");
    nv_cols += need("v_" + n, cv[j]);
    na_cols += need("a_" + n, ca[j]);
    if (!need("tau_" + n, ctau[j]) && model.effort_limit[j] > 0.0) return fail("missing column 'tau_" + n + "' (actuated joint)");
  }
  if (nv_cols != 0 && nv_cols != nj) return fail("v_ columns for some joints only (give all or none)");
  if (na_cols != 0 && na_cols != nj) return fail("a_ columns for some joints only (give all or none)");
  const bool has_va = nv_cols == nj && na_cols == nj;
  int cb_q[4], cb_w[3], cb_a[3], cb_dw[3], cb_p[3], cfp[2][6];
  bool has_dw = false, has_p = false;
  if (model.floating_base) {
    const char* qn[4] = {"base_qw", "base_qx", "base_qy", "base_qz"};
    for (int i = 0; i < 4; ++i)
      if (!need(qn[i], cb_q[i])) return fail(std::string("missing column '") + qn[i] + "'");
    const char* ax = "xyz";
    int ndw = 0, np = 0;
    for (int i = 0; i < 3; ++i) {
      if (!need(std::string("base_w") + ax[i], cb_w[i])) return fail(std::string("missing column 'base_w") + ax[i] + "'");
      if (!need(std::string("base_a") + ax[i], cb_a[i])) return fail(std::string("missing column 'base_a") + ax[i] + "'");
      ndw += need(std::string("base_dw") + ax[i], cb_dw[i]);
      np += need(std::string("base_p") + ax[i], cb_p[i]);
    }
    if (ndw % 3 || np % 3) return fail("base_dw* and base_p* come in threes");
    has_dw = ndw == 3;
    has_p = np == 3;
    const char* sides[2] = {"right", "left"};
    const char* comp[6] = {"fx", "fy", "fz", "nx", "ny", "nz"};
    for (int s = 0; s < 2; ++s)
      for (int k = 0; k < 6; ++k) {
        const std::string n = std::string("fp_") + sides[s] + "_" + comp[k];
        if (!need(n, cfp[s][k])) return fail("missing column '" + n + "' (floating base: plate wrenches are needed)");
      }
  }
  std::vector<std::string> cells;
  estimator::MeasuredSample s;
  s.q.resize(nj), s.tau.resize(nj);
  if (has_va) s.v.resize(nj), s.a.resize(nj);
  auto column = [&](int c) { return "column " + std::to_string(c + 1) + " '" + header[c] + "'"; };
  // A row that passed the cell checks: its values and line.
  struct Row {
    std::vector<double> val;
    Eigen::Quaterniond quat = Eigen::Quaterniond::Identity();
    long line = 0;
    int ct = 0;
    double t() const { return val[ct]; }
  };
  Row row, held;  // held: a row out of order that waits for the next one to tell a wild time from a gap
  bool holding = false;
  std::string failed;  // set when a row is an error (not skipped)
  auto bad = [&](long line, const std::string& reason, const std::string& detail) {
    const std::string where = "line " + std::to_string(line) + ", " + detail;
    if (!skip_bad_rows) return failed = at(line) + ": " + detail + " (--skip-bad-rows drops such rows)", false;
    stats.skip(reason, where);
    return true;
  };
  // The order rule: a time after the last accepted row's by at most kTimeJump typical steps (the median of the
  // last accepted ones, once there are 3) is in order.
  double last_t = -INFINITY;
  double steps[15];
  int nsteps = 0, step_at = 0;
  auto typicalStep = [&]() -> double {
    if (nsteps < 3) return INFINITY;
    double sorted[15];
    std::copy(steps, steps + nsteps, sorted);
    std::nth_element(sorted, sorted + nsteps / 2, sorted + nsteps);
    return sorted[nsteps / 2];
  };
  auto follows = [&](double before, double t) { return t > before && t - before <= kTimeJump * typicalStep(); };
  auto describe = [&](const Row& r) {
    std::ostringstream o;
    o << column(ct) << ": " << r.t();
    if (r.t() > last_t)
      o << " is " << r.t() - last_t << " s after the last accepted row's " << last_t << " (more than " << kTimeJump
        << " typical steps of " << typicalStep() << " s) and the next row does not follow it";
    else
      o << " is not after the last accepted row's " << last_t;
    return o.str();
  };
  std::string sink_error;
  auto accept = [&](const Row& r) {
    if (std::isfinite(last_t)) {
      steps[step_at] = r.t() - last_t;
      step_at = (step_at + 1) % 15;
      nsteps = std::min(nsteps + 1, 15);
    }
    last_t = r.t();
    const std::vector<double>& val = r.val;
    s.t = r.t();
    for (int j = 0; j < nj; ++j) {
      s.q[j] = val[cq[j]];
      s.tau[j] = ctau[j] >= 0 ? val[ctau[j]] : 0.0;
      if (has_va) s.v[j] = val[cv[j]], s.a[j] = val[ca[j]];
    }
    if (model.floating_base) {
      s.base_orientation = r.quat.normalized();
      for (int i = 0; i < 3; ++i) {
        s.base_omega[i] = val[cb_w[i]];
        s.base_acceleration[i] = val[cb_a[i]];
        s.base_domega[i] = has_dw ? val[cb_dw[i]] : 0.0;
        s.base_position[i] = has_p ? val[cb_p[i]] : 0.0;
      }
      s.has_base_domega = has_dw;
      s.has_base_position = has_p;
      s.ncontacts = 2;
      for (int sd = 0; sd < 2; ++sd) {
        s.contact[sd].body = feet[sd];
        s.contact[sd].force = Eigen::Vector3d(val[cfp[sd][0]], val[cfp[sd][1]], val[cfp[sd][2]]);
        s.contact[sd].moment_world_origin = Eigen::Vector3d(val[cfp[sd][3]], val[cfp[sd][4]], val[cfp[sd][5]]);
      }
    }
    if (!sink(s, &sink_error)) return failed = at(r.line) + ": " + sink_error, false;
    ++stats.samples;
    return true;
  };
  // A row in order is accepted; one out of order is held until the next row says which it was: the next row
  // follows the last accepted one (the held time was wild: it costs its own row), or follows the held one (a
  // forward jump was a gap in the recording: both accepted; a step back was a second recording or a clock
  // reset: an error, skipping the rest would silently lose it).
  auto place = [&](const Row& r) {
    if (holding) {
      holding = false;
      if (!follows(last_t, r.t()) && follows(held.t(), r.t())) {
        if (!(held.t() > last_t))
          return failed = at(held.line) + ": " + column(ct) + ": time goes back from " + std::to_string(last_t) + " to " +
                          std::to_string(held.t()) + " s and line " + std::to_string(r.line) +
                          " continues from it (two recordings in one file, or a clock reset; split the file)",
                 false;
        if (!accept(held)) return false;
      } else if (!bad(held.line, "time out of order", describe(held))) {
        return false;
      }
    }
    if (follows(last_t, r.t())) return accept(r);
    held = r;
    holding = true;
    return true;
  };
  while (std::getline(in, line)) {
    ++line_no;
    const bool at_eof = in.eof();  // no newline after this line: possibly truncated
    if (line.empty() || line[0] == '#' || line.find_first_not_of(" \t\r") == std::string::npos) continue;
    splitCells(line, cells);
    if (cells.size() != header.size()) {
      if (!bad(line_no, at_eof ? "truncated last line" : "wrong number of cells",
               std::to_string(cells.size()) + " cells, the header has " + std::to_string(header.size()) + (at_eof ? " (truncated last line)" : "")))
        break;
      continue;
    }
    row.val.resize(header.size());
    row.line = line_no;
    row.ct = ct;
    std::vector<double>& val = row.val;
    int bad_col = -1;
    for (size_t i = 0; i < cells.size() && bad_col < 0; ++i)
      if (!parseCell(cells[i], val[i])) bad_col = static_cast<int>(i);
    if (bad_col >= 0) {
      if (!bad(line_no, "not a finite number", column(bad_col) + ": '" + cells[bad_col] + "' is not a finite number")) break;
      continue;
    }
    // Plausibility: values no sensor of this robot can produce.
    std::string absurd;
    auto check = [&](int c, double limit_lo, double limit_hi) {
      if (absurd.empty() && c >= 0 && !(val[c] >= limit_lo && val[c] <= limit_hi)) {
        std::ostringstream o;
        o << column(c) << ": " << val[c] << " outside [" << limit_lo << ", " << limit_hi << "]";
        absurd = o.str();
      }
    };
    for (int j = 0; j < nj; ++j) {
      const bool limited = std::isfinite(model.position_lower[j]) && std::isfinite(model.position_upper[j]);
      check(cq[j], limited ? model.position_lower[j] - 1.0 : -100.0, limited ? model.position_upper[j] + 1.0 : 100.0);
      if (has_va) check(cv[j], -1e3, 1e3), check(ca[j], -1e5, 1e5);
      const double tl = model.effort_limit[j] > 0.0 ? 100.0 * model.effort_limit[j] : 1e5;
      check(ctau[j], -tl, tl);
    }
    if (model.floating_base)
      for (int sd = 0; sd < 2; ++sd)
        for (int k = 0; k < 3; ++k) check(cfp[sd][k], -1e6, 1e6);
    row.quat = Eigen::Quaterniond::Identity();
    if (model.floating_base && absurd.empty()) {
      row.quat = Eigen::Quaterniond(val[cb_q[0]], val[cb_q[1]], val[cb_q[2]], val[cb_q[3]]);
      if (std::abs(row.quat.norm() - 1.0) > 1e-3)
        absurd = "columns " + std::to_string(cb_q[0] + 1) + ".." + std::to_string(cb_q[3] + 1) +
                 " 'base_qw..qz': quaternion norm " + std::to_string(row.quat.norm()) + " (not unit)";
    }
    if (!absurd.empty()) {
      if (!bad(line_no, "absurd value", absurd)) break;
      continue;
    }
    if (!place(row)) break;
  }
  if (failed.empty() && holding) {
    std::string d = describe(held);
    const size_t at_next = d.find("and the next row does not follow it");
    if (at_next != std::string::npos) d.replace(at_next, std::string::npos, "and it is the last row");
    bad(held.line, "time out of order", d);
  }
  if (!failed.empty()) {
    if (error) *error = failed;
    return false;
  }
  if (stats.samples == 0) return fail("no usable data row");
  return true;
}

}  // namespace exoid::intake
