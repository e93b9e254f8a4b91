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

bool blankOrComment(const std::string& line) {
  return line.empty() || line[0] == '#' || line.find_first_not_of(" \t\r") == std::string::npos;
}

/// The header row: the first line that is not blank or a comment (a UTF-8 byte-order mark dropped).
void readHeader(std::istream& in, long& line_no, std::vector<std::string>& header) {
  std::string line;
  while (std::getline(in, line)) {
    ++line_no;
    if (line_no == 1 && line.size() >= 3 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);
    if (blankOrComment(line)) continue;
    splitCells(line, header);
    break;
  }
}

/// Where each quantity is in a row (-1: absent), and which optional groups the file gives.
struct CsvColumns {
  int t = -1;
  std::vector<int> q, v, a, tau;  ///< [njoints]
  int base_q[4], base_w[3], base_a[3], base_dw[3], base_p[3], plate[2][6];
  bool has_va = false, has_dw = false, has_p = false;
};

/// Every column must be one exoid knows (a misnamed joint is an error, not a silently ignored column).
bool checkKnownColumns(const std::vector<std::string>& header, const Model& model, std::string& why) {
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
    if (!known.count(h)) return why = "unknown column '" + h + "' (not a " + (model.floating_base ? "floating" : "fixed") + "-base column of this model's joints; docs/identification.md)", false;
  return true;
}

/// The floating base's columns: orientation, angular velocity and acceleration required, angular acceleration
/// and position optional (in threes), both plates' wrenches required.
bool mapBaseColumns(const std::function<bool(const std::string&, int&)>& need, CsvColumns& c, std::string& why) {
  const char* qn[4] = {"base_qw", "base_qx", "base_qy", "base_qz"};
  for (int i = 0; i < 4; ++i)
    if (!need(qn[i], c.base_q[i])) return why = std::string("missing column '") + qn[i] + "'", false;
  const char* ax = "xyz";
  int ndw = 0, np = 0;
  for (int i = 0; i < 3; ++i) {
    if (!need(std::string("base_w") + ax[i], c.base_w[i])) return why = std::string("missing column 'base_w") + ax[i] + "'", false;
    if (!need(std::string("base_a") + ax[i], c.base_a[i])) return why = std::string("missing column 'base_a") + ax[i] + "'", false;
    ndw += need(std::string("base_dw") + ax[i], c.base_dw[i]);
    np += need(std::string("base_p") + ax[i], c.base_p[i]);
  }
  if (ndw % 3 || np % 3) return why = "base_dw* and base_p* come in threes", false;
  c.has_dw = ndw == 3;
  c.has_p = np == 3;
  const char* sides[2] = {"right", "left"};
  const char* comp[6] = {"fx", "fy", "fz", "nx", "ny", "nz"};
  for (int s = 0; s < 2; ++s)
    for (int k = 0; k < 6; ++k) {
      const std::string n = std::string("fp_") + sides[s] + "_" + comp[k];
      if (!need(n, c.plate[s][k])) return why = "missing column '" + n + "' (floating base: plate wrenches are needed)", false;
    }
  return true;
}

/// Maps the header onto the model: names unique and known, the required columns present.
bool mapColumns(const std::vector<std::string>& header, const Model& model, CsvColumns& c, std::string& why) {
  std::map<std::string, int> col;
  for (size_t i = 0; i < header.size(); ++i) {
    if (header[i].empty()) return why = "header column " + std::to_string(i + 1) + " has no name", false;
    if (!col.emplace(header[i], static_cast<int>(i)).second) return why = "column '" + header[i] + "' appears twice", false;
  }
  const int nj = model.njoints;
  const std::function<bool(const std::string&, int&)> need = [&](const std::string& name, int& index) {
    auto it = col.find(name);
    index = it == col.end() ? -1 : it->second;
    return index >= 0;
  };
  if (!checkKnownColumns(header, model, why)) return false;
  if (!need("t", c.t)) return why = "missing column 't'", false;
  c.q.resize(nj), c.v.resize(nj), c.a.resize(nj), c.tau.resize(nj);
  int nv_cols = 0, na_cols = 0;
  for (int j = 0; j < nj; ++j) {
    const std::string& n = model.joint_names[j];
    if (!need("q_" + n, c.q[j])) return why = "missing column 'q_" + n + "'", false;
    nv_cols += need("v_" + n, c.v[j]);
    na_cols += need("a_" + n, c.a[j]);
    if (!need("tau_" + n, c.tau[j]) && model.effort_limit[j] > 0.0) return why = "missing column 'tau_" + n + "' (actuated joint)", false;
  }
  if (nv_cols != 0 && nv_cols != nj) return why = "v_ columns for some joints only (give all or none)", false;
  if (na_cols != 0 && na_cols != nj) return why = "a_ columns for some joints only (give all or none)", false;
  c.has_va = nv_cols == nj && na_cols == nj;
  return !model.floating_base || mapBaseColumns(need, c, why);
}

/// A row that passed the cell checks: its values and line.
struct Row {
  std::vector<double> val;
  Eigen::Quaterniond quat = Eigen::Quaterniond::Identity();
  long line = 0;
  int ct = 0;
  double t() const { return val[ct]; }
};

/// Plausibility: the first value no sensor of this robot can produce, described ("" if none). Sets row.quat.
std::string implausibleValue(const Model& model, const CsvColumns& c, Row& row,
                             const std::function<std::string(int)>& column) {
  const std::vector<double>& val = row.val;
  std::string absurd;
  auto check = [&](int k, double limit_lo, double limit_hi) {
    if (absurd.empty() && k >= 0 && !(val[k] >= limit_lo && val[k] <= limit_hi)) {
      std::ostringstream o;
      o << column(k) << ": " << val[k] << " outside [" << limit_lo << ", " << limit_hi << "]";
      absurd = o.str();
    }
  };
  for (int j = 0; j < model.njoints; ++j) {
    const bool limited = std::isfinite(model.position_lower[j]) && std::isfinite(model.position_upper[j]);
    check(c.q[j], limited ? model.position_lower[j] - 1.0 : -100.0, limited ? model.position_upper[j] + 1.0 : 100.0);
    if (c.has_va) check(c.v[j], -1e3, 1e3), check(c.a[j], -1e5, 1e5);
    const double tl = model.effort_limit[j] > 0.0 ? 100.0 * model.effort_limit[j] : 1e5;
    check(c.tau[j], -tl, tl);
  }
  if (model.floating_base) {
    // The base and the plates by the joints' bounds: rates 1e3, accelerations 1e5, forces and moments 1e6.
    for (int sd = 0; sd < 2; ++sd)
      for (int k = 0; k < 6; ++k) check(c.plate[sd][k], -1e6, 1e6);
    for (int i = 0; i < 3; ++i) {
      check(c.base_w[i], -1e3, 1e3), check(c.base_a[i], -1e5, 1e5);
      if (c.has_dw) check(c.base_dw[i], -1e5, 1e5);
      if (c.has_p) check(c.base_p[i], -1e4, 1e4);
    }
  }
  row.quat = Eigen::Quaterniond::Identity();
  if (model.floating_base && absurd.empty()) {
    row.quat = Eigen::Quaterniond(val[c.base_q[0]], val[c.base_q[1]], val[c.base_q[2]], val[c.base_q[3]]);
    if (std::abs(row.quat.norm() - 1.0) > 1e-3)
      absurd = "columns " + std::to_string(c.base_q[0] + 1) + ".." + std::to_string(c.base_q[3] + 1) +
               " 'base_qw..qz': quaternion norm " + std::to_string(row.quat.norm()) + " (not unit)";
  }
  return absurd;
}

/// An accepted row as a measured sample (s sized for the model).
void fillSample(const Model& model, const int feet[2], const CsvColumns& c, const Row& r,
                estimator::MeasuredSample& s) {
  const std::vector<double>& val = r.val;
  s.t = r.t();
  for (int j = 0; j < model.njoints; ++j) {
    s.q[j] = val[c.q[j]];
    s.tau[j] = c.tau[j] >= 0 ? val[c.tau[j]] : 0.0;
    if (c.has_va) s.v[j] = val[c.v[j]], s.a[j] = val[c.a[j]];
  }
  if (!model.floating_base) return;
  s.base_orientation = r.quat.normalized();
  for (int i = 0; i < 3; ++i) {
    s.base_omega[i] = val[c.base_w[i]];
    s.base_acceleration[i] = val[c.base_a[i]];
    s.base_domega[i] = c.has_dw ? val[c.base_dw[i]] : 0.0;
    s.base_position[i] = c.has_p ? val[c.base_p[i]] : 0.0;
  }
  s.has_base_domega = c.has_dw;
  s.has_base_position = c.has_p;
  s.ncontacts = 2;
  for (int sd = 0; sd < 2; ++sd) {
    s.contact[sd].body = feet[sd];
    s.contact[sd].force = Eigen::Vector3d(val[c.plate[sd][0]], val[c.plate[sd][1]], val[c.plate[sd][2]]);
    s.contact[sd].moment_world_origin = Eigen::Vector3d(val[c.plate[sd][3]], val[c.plate[sd][4]], val[c.plate[sd][5]]);
  }
}

/// The rows' order in time and what happens to each checked row: accepted into the sink, held, skipped
/// (skip_bad_rows) or an error (`failed`).
class RowSequencer {
 public:
  RowSequencer(const std::string& path, const Model& model, const int feet[2], bool skip_bad_rows,
               const SampleSink& sink, InputStats& stats, const CsvColumns& cols,
               const std::vector<std::string>& header)
      : path_(path), model_(model), feet_(feet), skip_bad_rows_(skip_bad_rows), sink_(sink), stats_(stats),
        cols_(cols), header_(header) {
    const int nj = model.njoints;
    s_.q.resize(nj), s_.tau.resize(nj);
    if (cols.has_va) s_.v.resize(nj), s_.a.resize(nj);
  }

  std::string column(int c) const { return "column " + std::to_string(c + 1) + " '" + header_[c] + "'"; }
  std::string at(long line) const { return path_ + ":" + std::to_string(line); }
  const std::string& failed() const { return failed_; }

  /// A bad row: skipped and counted (true) or, without skip_bad_rows, the error (false).
  bool bad(long line, const std::string& reason, const std::string& detail) {
    const std::string where = "line " + std::to_string(line) + ", " + detail;
    if (!skip_bad_rows_) return failed_ = at(line) + ": " + detail + " (--skip-bad-rows drops such rows)", false;
    stats_.skip(reason, where);
    return true;
  }

  /// A row in order is accepted; one out of order is held until the next row says which it was: the next row
  /// follows the last accepted one (the held time was wild: it costs its own row), or follows the held one (a
  /// forward jump was a gap in the recording: both accepted; a step back was a second recording or a clock
  /// reset: an error, skipping the rest would silently lose it).
  bool place(const Row& r) {
    if (holding_) {
      holding_ = false;
      if (!follows(last_t_, r.t()) && follows(held_.t(), r.t())) {
        if (!(held_.t() > last_t_))
          return failed_ = at(held_.line) + ": " + column(cols_.t) + ": time goes back from " + std::to_string(last_t_) + " to " +
                           std::to_string(held_.t()) + " s and line " + std::to_string(r.line) +
                           " continues from it (two recordings in one file, or a clock reset; split the file)",
                 false;
        if (!accept(held_)) return false;
      } else if (!bad(held_.line, "time out of order", describe(held_))) {
        return false;
      }
    }
    if (follows(last_t_, r.t())) return accept(r);
    held_ = r;
    holding_ = true;
    return true;
  }

  /// At the end of the file: a row still held had no next row to vouch for it.
  void finish() {
    if (!failed_.empty() || !holding_) return;
    std::string d = describe(held_);
    const size_t at_next = d.find("and the next row does not follow it");
    if (at_next != std::string::npos) d.replace(at_next, std::string::npos, "and it is the last row");
    bad(held_.line, "time out of order", d);
  }

 private:
  // The order rule: a time after the last accepted row's by at most kTimeJump typical steps (the median of the
  // last accepted ones, once there are 3) is in order.
  double typicalStep() const {
    if (nsteps_ < 3) return INFINITY;
    double sorted[15];
    std::copy(steps_, steps_ + nsteps_, sorted);
    std::nth_element(sorted, sorted + nsteps_ / 2, sorted + nsteps_);
    return sorted[nsteps_ / 2];
  }
  bool follows(double before, double t) const { return t > before && t - before <= kTimeJump * typicalStep(); }
  std::string describe(const Row& r) const {
    std::ostringstream o;
    o << column(cols_.t) << ": " << r.t();
    if (r.t() > last_t_)
      o << " is " << r.t() - last_t_ << " s after the last accepted row's " << last_t_ << " (more than " << kTimeJump
        << " typical steps of " << typicalStep() << " s) and the next row does not follow it";
    else
      o << " is not after the last accepted row's " << last_t_;
    return o.str();
  }
  bool accept(const Row& r) {
    if (std::isfinite(last_t_)) {
      steps_[step_at_] = r.t() - last_t_;
      step_at_ = (step_at_ + 1) % 15;
      nsteps_ = std::min(nsteps_ + 1, 15);
    }
    last_t_ = r.t();
    fillSample(model_, feet_, cols_, r, s_);
    if (!sink_(s_, &sink_error_)) return failed_ = at(r.line) + ": " + sink_error_, false;
    ++stats_.samples;
    return true;
  }

  const std::string& path_;
  const Model& model_;
  const int* feet_;
  bool skip_bad_rows_;
  const SampleSink& sink_;
  InputStats& stats_;
  const CsvColumns& cols_;
  const std::vector<std::string>& header_;
  estimator::MeasuredSample s_;
  Row held_;  // a row out of order that waits for the next one to tell a wild time from a gap
  bool holding_ = false;
  std::string failed_;  // set when a row is an error (not skipped)
  std::string sink_error_;
  double last_t_ = -INFINITY;
  double steps_[15];
  int nsteps_ = 0, step_at_ = 0;
};

/// Checks one data row (cell count, numbers, plausibility) and places it; false ends the stream.
bool readRow(const std::string& line, long line_no, bool at_eof, const Model& model, const CsvColumns& cols,
             const std::vector<std::string>& header, std::vector<std::string>& cells, Row& row, RowSequencer& seq) {
  splitCells(line, cells);
  if (cells.size() != header.size())
    return seq.bad(line_no, at_eof ? "truncated last line" : "wrong number of cells",
                   std::to_string(cells.size()) + " cells, the header has " + std::to_string(header.size()) + (at_eof ? " (truncated last line)" : ""));
  row.val.resize(header.size());
  row.line = line_no;
  row.ct = cols.t;
  int bad_col = -1;
  for (size_t i = 0; i < cells.size() && bad_col < 0; ++i)
    if (!parseCell(cells[i], row.val[i])) bad_col = static_cast<int>(i);
  if (bad_col >= 0)
    return seq.bad(line_no, "not a finite number", seq.column(bad_col) + ": '" + cells[bad_col] + "' is not a finite number");
  const std::string absurd = implausibleValue(model, cols, row, [&](int c) { return seq.column(c); });
  if (!absurd.empty()) return seq.bad(line_no, "absurd value", absurd);
  return seq.place(row);
}

}  // namespace

bool streamMeasuredCsv(const std::string& path, const Model& model, const int feet[2], bool skip_bad_rows,
                       const SampleSink& sink, InputStats& stats, std::string* error) {
  auto fail = [&](const std::string& m) {
    if (error) *error = path + ": " + m;
    return false;
  };
  stats = InputStats();
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    if (error) *error = "cannot open '" + path + "'";
    return false;
  }
  long line_no = 0;
  std::vector<std::string> header;
  readHeader(in, line_no, header);
  if (header.empty()) return fail("no header row");
  CsvColumns cols;
  std::string why;
  if (!mapColumns(header, model, cols, why)) return fail(why);
  // A row's place as an editor counts it (the header's line included) and a cell's column: number and name.
  RowSequencer seq(path, model, feet, skip_bad_rows, sink, stats, cols, header);
  std::string line;
  std::vector<std::string> cells;
  Row row;
  while (std::getline(in, line)) {
    ++line_no;
    const bool at_eof = in.eof();  // no newline after this line: possibly truncated
    if (blankOrComment(line)) continue;
    if (!readRow(line, line_no, at_eof, model, cols, header, cells, row, seq)) break;
  }
  seq.finish();
  if (!seq.failed().empty()) {
    if (error) *error = seq.failed();
    return false;
  }
  if (stats.samples == 0) return fail("no usable data row");
  return true;
}

}  // namespace exoid::intake
