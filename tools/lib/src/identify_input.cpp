#include "exoid/tools/identify_input.hpp"

#include <lcm/eventlog.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <vector>

#include "exoid/common/strict_number.hpp"
#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/lcm/safe_decode.hpp"

namespace exoid::tools {

namespace {
void skip(InputStats& st, const std::string& reason, const std::string& where) {
  ++st.skipped;
  ++st.why[reason];
  if (st.first_skip.empty()) st.first_skip = where + ": " + reason;
}

struct Pending {
  std::optional<RobotStateSample> state;
  std::optional<ForcePlateSample> plate[2];
  std::optional<GroundTruthSample> truth;
};
}  // namespace

bool streamRunLog(const std::string& path, const Model& model, LogPipeline pipeline, const int feet[2],
                  const SampleSink& sink, InputStats& stats, std::string* error) {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  stats = InputStats();
  std::unique_ptr<lcm_eventlog_t, void (*)(lcm_eventlog_t*)> file(lcm_eventlog_create(path.c_str(), "r"),
                                                                    [](lcm_eventlog_t* f) { if (f) lcm_eventlog_destroy(f); });
  if (!file) return fail("cannot open LCM log '" + path + "'");
  const bool truth = pipeline == LogPipeline::Truth;
  std::map<int64_t, Pending> pending;  // by tick; complete ticks leave in tick order
  int64_t last_done = -1, newest = -1;
  constexpr int64_t kWindow = 200;      // ticks a channel may lag before a tick is declared incomplete
  long events = 0, needed_events = 0;
  estimator::MeasuredSample sample;
  std::string sink_error;
  bool sink_failed = false;
  auto complete = [&](const Pending& p) { return p.plate[0] && p.plate[1] && (truth ? p.truth.has_value() : p.state.has_value()); };
  auto emit = [&](int64_t tick, const Pending& p) {
    const ForcePlateSample* plates[2] = {&*p.plate[0], &*p.plate[1]};
    if (truth) estimator::measuredFromTruth(model, *p.truth, plates, feet, sample);
    else estimator::measuredFromSensors(model, *p.state, plates, feet, sample);
    (void)tick;
    if (!sink(sample, &sink_error)) sink_failed = true;
    ++stats.samples;
  };
  auto drain = [&](bool all) {
    while (!pending.empty() && !sink_failed) {
      auto it = pending.begin();
      if (complete(it->second)) {
        emit(it->first, it->second);
      } else if (all || newest - it->first > kWindow) {
        skip(stats, "tick missing a needed message", "tick " + std::to_string(it->first));
      } else {
        break;
      }
      last_done = it->first;
      pending.erase(it);
    }
  };
  auto place = [&](int64_t tick, auto&& assign) {
    if (tick <= last_done) {
      skip(stats, "message for a tick already passed (out of order or repeated)", "tick " + std::to_string(tick));
      return;
    }
    newest = std::max(newest, tick);
    assign(pending[tick]);
  };
  while (lcm_eventlog_event_t* e = lcm_eventlog_read_next_event(file.get())) {
    ++events;
    const std::string channel(e->channel, e->channellen);
    std::string why;
    bool ok = true;
    if (channel == channels::kPlateRight || channel == channels::kPlateLeft) {
      ++needed_events;
      const int side = channel == channels::kPlateRight ? 0 : 1;
      exoid_lcm::force_plate_t msg;
      ForcePlateSample s;
      ok = safeDecode(e->data, e->datalen, msg) && fromLcm(msg, side, s, &why);
      if (ok) place(s.tick, [&](Pending& p) { if (!p.plate[side]) p.plate[side] = s; });
    } else if (channel == channels::kState && !truth) {
      ++needed_events;
      exoid_lcm::robot_state_t msg;
      RobotStateSample s;
      ok = safeDecode(e->data, e->datalen, msg) && fromLcm(msg, model.joint_names, s, &why);
      if (ok) place(s.tick, [&](Pending& p) { if (!p.state) p.state = s; });
    } else if (channel == channels::kTruth && truth) {
      ++needed_events;
      exoid_lcm::ground_truth_t msg;
      GroundTruthSample s;
      ok = safeDecode(e->data, e->datalen, msg) && fromLcm(msg, model.joint_names, s, &why);
      if (ok) place(s.tick, [&](Pending& p) { if (!p.truth) p.truth = s; });
    }
    if (!ok) {
      ++stats.rejected_events;
      skip(stats, "log event rejected", channel + " event " + std::to_string(events) + (why.empty() ? "" : " (" + why + ")"));
    }
    lcm_eventlog_free_event(e);
    drain(false);
    if (sink_failed) return fail(sink_error);
  }
  drain(true);
  if (sink_failed) return fail(sink_error);
  if (events == 0) return fail("'" + path + "' holds no LCM events (empty or not an LCM log)");
  if (needed_events == 0) {
    return fail("'" + path + "' has none of the channels the " + std::string(truth ? "truth" : "sensors") +
                " pipeline needs (" + (truth ? "EXO_TRUTH" : "EXO_STATE") + ", EXO_PLATE_RIGHT, EXO_PLATE_LEFT)");
  }
  return true;
}

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
  std::vector<double> val(header.size());
  estimator::MeasuredSample s;
  s.q.resize(nj), s.tau.resize(nj);
  if (has_va) s.v.resize(nj), s.a.resize(nj);
  double last_t = -INFINITY;
  std::string sink_error;
  while (std::getline(in, line)) {
    ++line_no;
    const bool at_eof = in.eof();  // no newline after this line: possibly truncated
    if (line.empty() || line[0] == '#' || line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::string where = "row " + std::to_string(line_no);
    auto bad = [&](const std::string& reason, const std::string& detail) {
      if (!skip_bad_rows) return fail(where + ": " + detail + " (--skip-bad-rows drops such rows)");
      skip(stats, reason, where + ", " + detail);
      return true;
    };
    splitCells(line, cells);
    if (cells.size() != header.size()) {
      if (!bad(at_eof ? "truncated last line" : "wrong number of cells",
               std::to_string(cells.size()) + " cells, the header has " + std::to_string(header.size()) + (at_eof ? " (truncated last line)" : "")))
        return false;
      continue;
    }
    int bad_col = -1;
    for (size_t i = 0; i < cells.size() && bad_col < 0; ++i)
      if (!parseCell(cells[i], val[i])) bad_col = static_cast<int>(i);
    if (bad_col >= 0) {
      if (!bad("not a finite number", "column '" + header[bad_col] + "': '" + cells[bad_col] + "' is not a finite number")) return false;
      continue;
    }
    const double t = val[ct];
    if (!(t > last_t)) {
      if (!bad("time not increasing", "column 't': " + std::to_string(t) + " is not after the previous row's " + std::to_string(last_t))) return false;
      continue;
    }
    // Plausibility: values no sensor of this robot can produce.
    std::string absurd;
    auto check = [&](int c, double limit_lo, double limit_hi) {
      if (absurd.empty() && c >= 0 && !(val[c] >= limit_lo && val[c] <= limit_hi)) {
        std::ostringstream o;
        o << "column '" << header[c] << "': " << val[c] << " outside [" << limit_lo << ", " << limit_hi << "]";
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
    Eigen::Quaterniond quat = Eigen::Quaterniond::Identity();
    if (model.floating_base && absurd.empty()) {
      quat = Eigen::Quaterniond(val[cb_q[0]], val[cb_q[1]], val[cb_q[2]], val[cb_q[3]]);
      if (std::abs(quat.norm() - 1.0) > 1e-3) absurd = "base quaternion norm " + std::to_string(quat.norm()) + " (not unit)";
    }
    if (!absurd.empty()) {
      if (!bad("absurd value", absurd)) return false;
      continue;
    }
    last_t = t;
    s.t = t;
    for (int j = 0; j < nj; ++j) {
      s.q[j] = val[cq[j]];
      s.tau[j] = ctau[j] >= 0 ? val[ctau[j]] : 0.0;
      if (has_va) s.v[j] = val[cv[j]], s.a[j] = val[ca[j]];
    }
    if (model.floating_base) {
      s.base_orientation = quat.normalized();
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
    if (!sink(s, &sink_error)) return fail(where + ": " + sink_error);
    ++stats.samples;
  }
  if (stats.samples == 0) return fail("no usable data row");
  return true;
}

bool isCsvPath(const std::string& path) {
  return path.size() >= 4 && (path.compare(path.size() - 4, 4, ".csv") == 0 || path.compare(path.size() - 4, 4, ".CSV") == 0);
}

namespace {
// The feet (floating base) and the dataset options with the sole footholds filled in.
bool datasetSetup(const Model& model, const SourceOptions& options, int feet[2], estimator::DatasetOptions& dopt,
                  std::string* error) {
  feet[0] = feet[1] = -1;
  dopt = options.dataset;
  if (model.floating_base) {
    feet[0] = model.bodyIndex("right_foot");
    feet[1] = model.bodyIndex("left_foot");
    if (feet[0] < 0 || feet[1] < 0) {
      if (error) *error = "a floating-base identification needs the model's right_foot and left_foot links";
      return false;
    }
    if (dopt.footholds.empty()) dopt.footholds = estimator::defaultFootholds(model);
  }
  return true;
}

bool readFile(const std::string& path, const Model& model, const SourceOptions& options, const int feet[2],
              const SampleSink& sink, InputStats& stats, std::string* error) {
  return isCsvPath(path) ? streamMeasuredCsv(path, model, feet, options.skip_bad_rows, sink, stats, error)
                         : streamRunLog(path, model, options.pipeline, feet, sink, stats, error);
}

estimator::RowSink accumulatorSink(estimator::LsqAccumulator& acc, long& nonfinite) {
  return [&acc, &nonfinite](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
    if (!acc.add(K, y)) ++nonfinite;
  };
}

// A sample of a run with the pelvis held by a harness (SourceOptions::held_base): the base at rest, no contact.
void heldBase(estimator::MeasuredSample& s) {
  s.base_omega.setZero();
  s.base_domega.setZero();
  s.base_acceleration.setZero();
  s.has_base_domega = true;
  s.has_base_position = true;  // not needed by K; keeps the footholds (feet on the plates) out of it
  s.ncontacts = 0;
}

using BuilderRowSink = std::function<void(const estimator::DatasetBuilder& builder, double t, const Eigen::MatrixXd& K,
                                          const Eigen::VectorXd& y)>;

// Streams a file's rows through the dataset builder and, when the source has a sidecar, its corrections.
bool streamRows(const std::string& path, const Model& model, const SourceOptions& options, const BuilderRowSink& rows,
                InputStats& stats, std::string* error) {
  int feet[2];
  estimator::DatasetOptions dopt;
  if (!datasetSetup(model, options, feet, dopt, error)) return false;
  if (options.held_base && !model.floating_base) {
    if (error) *error = path + ": a held base needs a floating-base model";
    return false;
  }
  if (options.held_base) dopt.orientation_from_legs = false;  // the feet swing: they say nothing of the base
  const estimator::DatasetBuilder* self = nullptr;
  Eigen::MatrixXd Kh;  // held base: the rows with the unmeasured ones (heldBaseRowMeasured) zeroed
  Eigen::VectorXd yh;
  const estimator::RowSink direct = [&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
    if (!options.held_base) return rows(*self, t, K, y);
    Kh = K, yh = y;
    for (int r = 0; r < model.nv; ++r)
      if (!estimator::heldBaseRowMeasured(model, r)) Kh.row(r).setZero(), yh[r] = 0.0;
    rows(*self, t, Kh, yh);
  };
  std::unique_ptr<estimator::EffectCorrector> corrector;
  if (options.effects) corrector = std::make_unique<estimator::EffectCorrector>(model, *options.effects, direct);
  estimator::DatasetBuilder builder(model, dopt, corrector ? estimator::RowSink([&](double t, const Eigen::MatrixXd& K,
                                                                                     const Eigen::VectorXd& y) {
                                                   corrector->add(t, K, y, &self->sensorTorque());
                                                 })
                                                           : direct);
  self = &builder;
  estimator::MeasuredSample held;
  const SampleSink sink = [&](const estimator::MeasuredSample& s, std::string* err) {
    if (!options.held_base) return builder.add(s, err);
    held = s;
    heldBase(held);
    return builder.add(held, err);
  };
  if (!readFile(path, model, options, feet, sink, stats, error)) return false;
  std::string err;
  if (!builder.finish(&err)) {
    if (error) *error = path + ": " + err;
    return false;
  }
  if (corrector) corrector->finish();
  return true;
}
}  // namespace

bool streamFileRows(const std::string& path, const Model& model, const SourceOptions& options,
                    const estimator::RowSink& rows, InputStats& stats, std::string* error) {
  return streamRows(
      path, model, options,
      [&](const estimator::DatasetBuilder&, double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) { rows(t, K, y); },
      stats, error);
}

bool streamFileRows(const std::string& path, const Model& model, const SourceOptions& options,
                    const TorqueRowSink& rows, InputStats& stats, std::string* error) {
  if (options.effects) {  // the corrector delays rows by one sample: the builder's torque would be the next one's
    if (error) *error = "streamFileRows: sensor torques and sidecar corrections together are not supported";
    return false;
  }
  return streamRows(
      path, model, options,
      [&](const estimator::DatasetBuilder& b, double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
        rows(t, K, y, b.sensorTorque());
      },
      stats, error);
}

bool streamFileStateRows(const std::string& path, const Model& model, const SourceOptions& options,
                         const StateRowSink& rows, InputStats& stats, std::string* error) {
  if (options.effects) {
    if (error) *error = "streamFileStateRows: sensor torques and sidecar corrections together are not supported";
    return false;
  }
  return streamRows(
      path, model, options,
      [&](const estimator::DatasetBuilder& b, double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
        rows(t, K, y, b.sensorTorque(), b.jointPosition());
      },
      stats, error);
}

bool readSamples(const std::string& path, const Model& model, const SourceOptions& options,
                 std::vector<estimator::MeasuredSample>& out, InputStats& stats, std::string* error) {
  if (options.held_base) {  // the study's path: held-base runs go through streamFileRows
    if (error) *error = "readSamples: held-base runs are not supported here";
    return false;
  }
  int feet[2];
  estimator::DatasetOptions dopt;
  if (!datasetSetup(model, options, feet, dopt, error)) return false;
  out.clear();
  const SampleSink sink = [&](const estimator::MeasuredSample& s, std::string*) { return out.push_back(s), true; };
  return readFile(path, model, options, feet, sink, stats, error);
}

bool accumulateSamples(const std::vector<estimator::MeasuredSample>& samples, const Model& model,
                       const SourceOptions& options, estimator::LsqAccumulator& acc, InputStats& stats,
                       std::string* error) {
  if (options.effects || options.held_base) {  // the study's path; a sidecar, a held base go through streamFileRows
    if (error) *error = "accumulateSamples: sidecar corrections and held-base runs are not supported here";
    return false;
  }
  int feet[2];
  estimator::DatasetOptions dopt;
  if (!datasetSetup(model, options, feet, dopt, error)) return false;
  long nonfinite = 0;
  estimator::DatasetBuilder builder(model, dopt, accumulatorSink(acc, nonfinite));
  for (const estimator::MeasuredSample& s : samples)
    if (!builder.add(s, error)) return false;
  if (!builder.finish(error)) return false;
  stats.samples = static_cast<long>(samples.size());
  if (nonfinite > 0) {
    stats.skipped += nonfinite;
    stats.why["non-finite regressor row"] += nonfinite;
  }
  return true;
}

bool accumulateFile(const std::string& path, const Model& model, const SourceOptions& options,
                    estimator::LsqAccumulator& acc, InputStats& stats, std::string* error) {
  long nonfinite = 0;
  if (!streamFileRows(path, model, options, accumulatorSink(acc, nonfinite), stats, error)) return false;
  if (nonfinite > 0) {
    stats.skipped += nonfinite;
    stats.why["non-finite regressor row"] += nonfinite;
  }
  return true;
}

}  // namespace exoid::tools
