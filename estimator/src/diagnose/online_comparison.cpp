// The online estimator with and without the diagnosis's sidecar columns, offline (diagnose.hpp compareOnline).
#include <cmath>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/diagnose.hpp"
#include "exoid/estimator/online/recursive_ls.hpp"

namespace exoid::estimator {

namespace {
// Both estimators on one segment's rows: training rows update them (tick counted over all training segments),
// validation rows are predicted and their squared errors summed per coordinate (measured rows only).
struct OnlinePair {
  RecursiveLsModel rigid, augmented;
  long tick = 0, refused = 0;
  Eigen::VectorXd sse_b, sse_a, n_row;
};

bool streamOnline(const Model& model, const EffectSet& set, const Segment& sg, const ResidualSeries& rs, OnlinePair& op,
                  RecursiveLsData& dr, RecursiveLsData& da, std::string* error) {
  const int nv = model.nv, p = model.nparams(), ne = op.augmented.p - op.rigid.p;
  Eigen::MatrixXd Ka(nv, p + ne);
  Eigen::VectorXd ya(nv), pr(nv), pa(nv);
  long i = 0;
  return sg.stream(
      [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd& tau_sensor) {
        if (i >= rs.t.size()) return;
        Ka.leftCols(p) = K;
        const Eigen::VectorXd qi = rs.q.rows() > i ? Eigen::VectorXd(rs.q.row(i).transpose()) : Eigen::VectorXd::Zero(model.njoints);
        effectColumns(model, set, qi, rs.v.row(i).transpose(), rs.a.row(i).transpose(), Ka.rightCols(ne));
        ya = y;
        correctMeasurement(model, set, ya, tau_sensor);
        if (!rs.validation) {
          ++op.tick;
          op.refused += updateRecursiveLs(op.rigid, dr, op.tick, K, y) != SampleStatus::Accepted;
          op.refused += updateRecursiveLs(op.augmented, da, op.tick, Ka, ya) != SampleStatus::Accepted;
        } else {
          predictRecursiveLs(op.rigid, dr, K, pr);
          predictRecursiveLs(op.augmented, da, Ka, pa);
          // Back to measured units: the predicted sensor part tau = pa - (y - tau_sensor) scaled by (1 + g).
          for (const Effect& e : set.effects)
            if (e.kind == EffectKind::GainError) {
              const int r = model.jointRow(e.joint);
              pa[r] += e.value * (pa[r] - (y[r] - tau_sensor[r]));
            }
          for (int r = 0; r < nv; ++r) {
            if (!segmentRowMeasured(model, sg, r)) continue;  // a zero row, not data
            op.sse_b[r] += (y[r] - pr[r]) * (y[r] - pr[r]);
            op.sse_a[r] += (y[r] - pa[r]) * (y[r] - pa[r]);
            op.n_row[r] += 1.0;
          }
        }
        ++i;
      },
      error);
}
}  // namespace

bool compareOnline(const Model& model, const DiagnoseOptions& opt, const std::vector<Segment>& train,
                   const std::vector<Segment>& validate, const DiagnosisResult& res, const EffectSet& set,
                   OnlineComparison& out, std::string* error) {
  out = OnlineComparison{};
  if (validate.empty() || set.effects.empty() || opt.hold_declared) return true;
  const int nv = model.nv;
  const BaseParameters base = computeBaseParameters(model);
  const Eigen::MatrixXd info = diagonalPriorInformation(model, base, model.phi, 0.25);
  OnlinePair op;
  if (!makeRecursiveLs(model, base, model.phi, info, {}, op.rigid, error)) return false;
  op.augmented = op.rigid;
  std::vector<int> rows;
  std::vector<double> sig;
  for (const Effect& e : set.effects)
    if (!isMeasurementEffect(e.kind)) rows.push_back(model.jointRow(e.joint)), sig.push_back(10.0 * std::fabs(e.value) + 1e-6);
  if (!addExtraColumns(op.augmented, rows, Eigen::Map<Eigen::VectorXd>(sig.data(), sig.size()), error)) return false;
  RecursiveLsData dr(op.rigid), da(op.augmented);
  op.sse_b = op.sse_a = op.n_row = Eigen::VectorXd::Zero(nv);
  for (size_t sgi = 0; sgi < res.series.size(); ++sgi) {
    const Segment& sg = sgi < train.size() ? train[sgi] : validate[sgi - train.size()];
    if (!streamOnline(model, set, sg, res.series[sgi], op, dr, da, error)) return false;
    if (op.refused > 0) {
      if (error) *error = "the online comparison refused " + std::to_string(op.refused) + " training rows (non-finite)";
      return false;
    }
    if (sgi + 1 == train.size()) {
      solveRecursiveLs(op.rigid, dr, false);
      solveRecursiveLs(op.augmented, da, false);
    }
  }
  const int j0 = model.floating_base ? 6 : 0;
  const Eigen::ArrayXd n_joint = op.n_row.tail(nv - j0).array().max(1.0);
  out.ran = true;
  out.joint_before = (op.sse_b.tail(nv - j0).array() / n_joint).sqrt().matrix();
  out.joint_after = (op.sse_a.tail(nv - j0).array() / n_joint).sqrt().matrix();
  out.before = std::sqrt(op.sse_b.tail(nv - j0).sum() / std::max(op.n_row.tail(nv - j0).sum(), 1.0));
  out.after = std::sqrt(op.sse_a.tail(nv - j0).sum() / std::max(op.n_row.tail(nv - j0).sum(), 1.0));
  return true;
}

}  // namespace exoid::estimator
