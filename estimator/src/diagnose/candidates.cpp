// The candidate columns of the diagnosis and the per-(fold, coordinate) factors they are tested on
// (diagnose_stages.hpp, docs/diagnose.md).
#include <algorithm>

#include "exoid/estimator/diagnose_stages.hpp"
#include "exoid/common/fail.hpp"

namespace exoid::estimator {

void candidateSignals(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data, DiagnosisResult& out) {
  const int nv = data.nv, m = data.m;
  data.cands.clear();
  const std::vector<std::vector<int>> neighbours = kinematicNeighbours(model);
  for (EffectKind k : opt.kinds)
    for (int j = 0; j < data.nj; ++j) {
      const int r = model.jointRow(j);
      if (opt.declared_friction && (k == EffectKind::Viscous || k == EffectKind::Coulomb)) continue;
      if (isElastic(k) && (!data.has_q || (k == EffectKind::ElasticExp && opt.elastic_scales.empty()))) continue;
      bool measured = false;
      for (size_t s = 0; s < data.ntrain; ++s) measured = measured || data.caches[s].y.col(r).cwiseAbs().maxCoeff() > 0;
      // A gain error needs a torque sensor: a measured torque and an actuated joint (URDF effort > 0).
      const bool sensed = measured && (model.effort_limit.size() != data.nj || model.effort_limit[j] > 0);
      if (k == EffectKind::GainError && !sensed) continue;
      const size_t js = static_cast<size_t>(j);
      if (k == EffectKind::ElasticCoupled) {  // one candidate per kinematic neighbour: the angle of that joint
        for (int c : neighbours[js]) data.cands.push_back({k, j, r, 0.0, data.center_of[static_cast<size_t>(c)], c});
        continue;
      }
      if (k == EffectKind::ElasticExpCoupled) {  // one per profiled (joint, neighbour) pair: its scale and ratio
        for (size_t pi = 0; pi < data.cprofile.size(); ++pi)
          if (const int c = data.cprofile[pi].coupled; data.cprofile[pi].joint == j)
            data.cands.push_back({k, j, r, data.cscale_of[pi], data.center_of[js], c, data.cratio_of[pi],
                                  data.center_of[static_cast<size_t>(c)]});
        continue;
      }
      const double width = isDryFriction(k)                ? data.width_of[2 * js + (k == EffectKind::Stribeck)]
                           : k == EffectKind::ElasticExp ? data.scale_of[js]
                                                         : 0.0;
      data.cands.push_back({k, j, r, width, isElastic(k) ? data.center_of[js] : 0.0, -1});
    }
  const int nc = data.nc = static_cast<int>(data.cands.size());
  out.candidates = nc;
  data.P = m + nc + 4 * data.npl + 1, data.iy = data.P - 1;  // columns: declared, candidates, payloads (4 per link), y
  data.pc0 = m + nc;                                           // the first payload column
  // Active columns (P-space) of each coordinate.
  data.active.assign(nv, {});
  for (int r = 0; r < nv; ++r) {
    std::vector<int>& act = data.active[r];
    for (int c = 0; c < m; ++c)
      if (data.touched[r][c]) act.push_back(c);
    for (int c = 0; c < nc; ++c)
      if (data.cands[c].coord == r) act.push_back(m + c);
    for (int l = 0; l < data.npl; ++l)
      if (data.ptouch[r][l])
        for (int k = 0; k < 4; ++k) act.push_back(data.pc0 + 4 * l + k);
    act.push_back(data.iy);
  }
  data.measurement_cands = false;
  for (const DiagnosisCandidate& cd : data.cands) data.measurement_cands = data.measurement_cands || isMeasurementEffect(cd.kind);
}

int payloadParameter(const Model& model, const DiagnoseData& data, int c) {
  return model.bodyParamIndex(data.plinks[(c - data.pc0) / 4]) + (c - data.pc0) % 4;
}

double candidateSignal(const Model& model, const DiagnoseOptions& opt, const DiagnoseData& data, size_t s, long i,
                       const DiagnosisCandidate& cd) {
  if (data.unmeasured(model, s, cd.coord)) return 0.0;
  const SegmentSignals& c = data.caches[s];
  // Gain and delay act on the torque sensor only: the model's prediction of the sensor's part of y (y minus what the
  // plates contribute; all of y for a fixed base).
  const Effect e = candidateEffect(cd, 0.0);
  const double angle = c.q.rows() > i ? effectAngle(e, c.q(i, cd.joint), c.q(i, signalJoint(e))) : 0.0;
  return effectSignal(cd.kind, effectShape(opt.shape, e), angle, c.v(i, cd.joint), c.a(i, cd.joint),
                      c.tau(i, cd.coord) - c.ext(i, cd.coord), c.dtau(i, cd.coord) - c.dext(i, cd.coord));
}

namespace {
// The P-space column c's value on row r of a sample: declared column, candidate signal, payload column or y.
double problemEntry(const Model& model, const DiagnoseOptions& opt, const DiagnoseData& data, size_t s, long i, int r,
                    int c, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
  const int m = data.m;
  if (c < m) return K(r, data.decl[c]);
  if (c < data.pc0) return candidateSignal(model, opt, data, s, i, data.cands[c - m]);
  if (c < data.iy) return K(r, payloadParameter(model, data, c));
  return y[r];
}
}  // namespace

Eigen::MatrixXd mergeFoldFactors(const DiagnoseData& data, const std::vector<std::pair<int, int>>& which, bool unweight) {
  long rows = 0;
  for (auto& fr : which) rows += static_cast<long>(data.active[fr.second].size());
  Eigen::MatrixXd stack = Eigen::MatrixXd::Zero(rows, data.P);
  long at = 0;
  for (auto& fr : which) {
    const std::vector<int>& act = data.active[fr.second];
    const Eigen::MatrixXd& R = data.fc[fr.first * data.nv + fr.second].R();
    const double scale = unweight ? data.sigma[fr.second] : 1.0;
    for (size_t k = 0; k < act.size(); ++k) stack.block(at, act[k], act.size(), 1) = scale * R.col(k);
    at += static_cast<long>(act.size());
  }
  return TriangularFactor::triangular(stack);
}

bool foldFactors(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data, std::string* error) {
  const int nv = data.nv, F = opt.folds, P = data.P;
  data.fc.resize(static_cast<size_t>(F) * nv);
  for (int f = 0; f < F; ++f)
    for (int r = 0; r < nv; ++r) data.fc[f * nv + r].reset(static_cast<int>(data.active[r].size()), 0);
  for (size_t s = 0; s < data.ntrain; ++s) {
    const SegmentSignals& cache = data.caches[s];
    long i = 0;
    const bool ok = data.segment(s).stream(
        [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd&) {
          if (i >= cache.n) return;
          const int f = static_cast<int>(static_cast<long>((cache.t[i] - cache.t[0]) / opt.chunk_seconds) % F);
          for (int r = 0; r < nv; ++r) {
            auto row = data.fc[f * nv + r].nextRow();
            const std::vector<int>& act = data.active[r];
            for (size_t k = 0; k < act.size(); ++k) row[k] = problemEntry(model, opt, data, s, i, r, act[k], K, y) / data.sigma[r];
          }
          ++i;
        },
        error);
    if (!ok) return false;
    if (i != cache.n) return common::fail(error, data.segment(s).name + ": the data changed between two reads");
  }
  for (TriangularFactor& t : data.fc) t.flush();
  // Scatter the coordinate factors into P-space: per fold, then training-without-fold and all.
  data.Rfold.assign(F, Eigen::MatrixXd());
  data.Rtrain.assign(F + 1, Eigen::MatrixXd());
  for (int f = 0; f < F; ++f) {
    std::vector<std::pair<int, int>> w;
    for (int r = 0; r < nv; ++r) w.push_back({f, r});
    data.Rfold[f] = mergeFoldFactors(data, w, false);
  }
  for (int f = 0; f <= F; ++f) {
    Eigen::MatrixXd stack((f < F ? F - 1 : F) * P, P);
    long at = 0;
    for (int g = 0; g < F; ++g)
      if (g != f) stack.middleRows(at, P) = data.Rfold[g], at += P;
    data.Rtrain[f] = TriangularFactor::triangular(stack);  // Rtrain[F]: all training data
  }
  return true;
}

}  // namespace exoid::estimator
