// The declared model's stages of the diagnosis (diagnose_stages.hpp): its columns, the training pass, its fit and
// prediction, the row weights.
#include <Eigen/QR>
#include <algorithm>
#include <cmath>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/diagnose_stages.hpp"
#include "exoid/common/fail.hpp"

namespace exoid::estimator {

Eigen::MatrixXd centralDifference(const std::vector<double>& t, const Eigen::MatrixXd& x) {
  const long n = x.rows();
  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(n, x.cols());
  if (n < 2) return d;
  for (long i = 0; i < n; ++i) {
    const long lo = std::max(0L, i - 1), hi = std::min(n - 1, i + 1);
    const double dt = t[hi] - t[lo];
    if (dt > 0) d.row(i) = (x.row(hi) - x.row(lo)) / dt;
  }
  return d;
}

void declaredColumns(const Model& model, const DiagnoseOptions& opt, const std::vector<Segment>& train,
                     const std::vector<Segment>& validate, DiagnoseData& data, DiagnosisResult& out) {
  const int nv = data.nv = model.nv;
  data.nj = model.njoints;
  data.p = model.nparams();
  for (int r = 0; r < nv; ++r) {
    static const char* kBase[6] = {"base_nx", "base_ny", "base_nz", "base_fx", "base_fy", "base_fz"};
    out.coordinate_names.push_back(model.floating_base && r < 6 ? kBase[r] : model.joint_names[r - (model.floating_base ? 6 : 0)]);
  }
  data.segments.clear();
  for (const Segment& s : train) data.segments.push_back(&s);
  for (const Segment& s : validate) data.segments.push_back(&s);
  data.ntrain = train.size();
  data.caches.assign(data.segments.size(), SegmentSignals{});
  data.has_q = true;
  for (const Segment* s : data.segments) data.has_q = data.has_q && s->stream_state != nullptr;
  const BaseParameters base = computeBaseParameters(model);
  data.decl.clear();
  for (int c : base.independent)
    if ((opt.declared_friction || c < model.nInertialParams()) && !(opt.hold_declared && c < model.nInertialParams()))
      data.decl.push_back(c);  // held rigid-body parameters: the caller took K phi_declared off y
  std::sort(data.decl.begin(), data.decl.end());
  data.md = static_cast<int>(data.decl.size());
  data.touched.assign(nv, std::vector<char>(data.md, 0));
  // Payload candidates: per moving link, its m, mcx, mcy, mcz columns of K (held declared model only: an identified
  // link absorbs a payload).
  data.plinks.clear();
  for (int b = 0; opt.payload && opt.hold_declared && b < model.nbodies; ++b) data.plinks.push_back(b);
  data.npl = static_cast<int>(data.plinks.size());
  data.ptouch.assign(nv, std::vector<char>(static_cast<size_t>(data.npl), 0));
}

namespace {
// One training sample's width-profile sums on every measured joint row: K_j^T s, s^T s, s^T y_j, s^T v with
// s = [Coulomb per width, Stribeck per width, v].
void addWidthProfile(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data, size_t s,
                     const Eigen::MatrixXd& K, const Eigen::VectorXd& y, Eigen::VectorXd& sig) {
  const int nw = data.nw, ns2 = 2 * nw;
  for (int j = 0; j < data.nj; ++j) {
    const int r = model.jointRow(j);
    if (data.unmeasured(model, s, r)) continue;
    const double v = K(r, model.frictionParamIndex(j));
    for (int w = 0; w < nw; ++w) {
      EffectShape sh = opt.shape;
      sh.coulomb_width = data.widths[w];
      sig[w] = effectSignal(EffectKind::Coulomb, sh, 0.0, v, 0.0, 0.0, 0.0);
      sig[nw + w] = effectSignal(EffectKind::Stribeck, sh, 0.0, v, 0.0, 0.0, 0.0);
    }
    sig[ns2] = v;
    WidthProfileSums& pr = data.profile[static_cast<size_t>(j)];
    for (int c = 0; c < data.md; ++c)
      if (const double k = K(r, data.decl[c]); k != 0.0) pr.B.row(c) += k * sig.transpose();
    pr.cc += sig.cwiseAbs2();
    pr.cy += y[r] * sig;
    pr.cv += v * sig;
  }
}

// The segment's rows through `sink`, with the joint positions appended to qs [n x nj, row-major] when it streams them
// (Segment::stream_state); a q of the wrong size sets *size_error.
bool streamWithPositions(const Segment& seg, int nj, std::vector<double>& qs, std::string& size_error,
                         const DiagnosisRowSink& sink, std::string* error) {
  if (!seg.stream_state) return seg.stream(sink, error);
  return seg.stream_state(
      [&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd& tau_sensor,
          const Eigen::VectorXd& q) {
        if (q.size() != nj) {
          size_error = seg.name + ": a sample's joint positions do not match the model's joints";
          return;
        }
        qs.insert(qs.end(), q.data(), q.data() + nj);
        sink(t, K, y, tau_sensor);
      },
      error);
}

// One training sample's elastic-profile sums on every measured joint row (ElasticProfileSums).
void addElasticProfile(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data, size_t s, const Eigen::MatrixXd& K,
                       const Eigen::VectorXd& y, const Eigen::VectorXd& q, Eigen::VectorXd& z) {
  const int ne = static_cast<int>(opt.elastic_scales.size());
  if (data.q_ref.empty()) data.q_ref.assign(q.data(), q.data() + q.size());
  for (int j = 0; j < data.nj; ++j) {
    const int r = model.jointRow(j);
    if (data.unmeasured(model, s, r)) continue;
    const double x = q[j] - data.q_ref[static_cast<size_t>(j)];
    for (int k = 0; k < ne; ++k) {
      EffectShape sh;
      sh.elastic_scale = opt.elastic_scales[k];
      z[k] = effectSignal(EffectKind::ElasticExp, sh, x, 0.0, 0.0, 0.0, 0.0);  // about q_ref (center 0)
    }
    z[ne] = x, z[ne + 1] = 1.0;
    ElasticProfileSums& pr = data.eprofile[static_cast<size_t>(j)];
    for (int c = 0; c < data.md; ++c)
      if (const double k = K(r, data.decl[c]); k != 0.0) pr.B.row(c) += k * z.transpose();
    pr.G.selfadjointView<Eigen::Lower>().rankUpdate(z);
    pr.zy += y[r] * z;
    pr.qsum += q[j];
    ++pr.n;
  }
}

// One training sample's ElasticExpCoupled-profile sums on every (joint, neighbour) pair whose joint row is measured
// (CoupledElasticProfileSums; q_ref set by addElasticProfile).
void addCoupledProfile(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data, size_t s, const Eigen::MatrixXd& K,
                       const Eigen::VectorXd& y, const Eigen::VectorXd& q, Eigen::VectorXd& z) {
  const int ns = static_cast<int>(opt.coupled_elastic_scales.size()), nr = static_cast<int>(opt.coupled_elastic_ratios.size());
  const int ng = ns * nr;
  for (CoupledElasticProfileSums& pr : data.cprofile) {
    const int r = model.jointRow(pr.joint);
    if (data.unmeasured(model, s, r)) continue;
    const double xj = q[pr.joint] - data.q_ref[static_cast<size_t>(pr.joint)];
    const double xc = q[pr.coupled] - data.q_ref[static_cast<size_t>(pr.coupled)];
    for (int a = 0; a < ns; ++a) {
      EffectShape sh;
      sh.elastic_scale = opt.coupled_elastic_scales[a];
      for (int b = 0; b < nr; ++b)
        z[a * nr + b] = effectSignal(EffectKind::ElasticExpCoupled, sh, xj + opt.coupled_elastic_ratios[b] * xc, 0, 0, 0, 0);
    }
    z[ng] = xj, z[ng + 1] = xc, z[ng + 2] = 1.0;
    for (int c = 0; c < data.md; ++c)
      if (const double k = K(r, data.decl[c]); k != 0.0) pr.B.row(c) += k * z.transpose();
    pr.G.col(0) += z.cwiseAbs2();
    pr.G.col(1) += xj * z, pr.G.col(2) += xc * z, pr.G.col(3) += z;
    pr.zy += y[r] * z;
  }
}

// One training sample's rows into the declared factor, with the (coordinate, column) and payload excitation.
void addDeclaredRows(const Model& model, DiagnoseData& data, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
  const int md = data.md;
  for (int r = 0; r < data.nv; ++r) {
    auto row = data.declared_factor.nextRow();
    for (int c = 0; c < md; ++c) {
      row[c] = K(r, data.decl[c]);
      if (row[c] != 0.0) data.touched[r][c] = 1;
    }
    row[md] = y[r];
    for (int l = 0; l < data.npl; ++l)
      for (int k = 0; k < 4 && !data.ptouch[r][l]; ++k)
        if (K(r, model.bodyParamIndex(data.plinks[l]) + k) != 0.0) data.ptouch[r][l] = 1;
  }
}
}  // namespace

bool trainingPass(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data, DiagnosisResult& out,
                  std::string* error) {
  const int nv = data.nv, nj = data.nj;
  data.declared_factor.reset(data.md + 1, 0);
  data.widths = opt.coulomb_widths.empty() ? std::vector<double>{opt.shape.coulomb_width} : opt.coulomb_widths;
  data.nw = static_cast<int>(data.widths.size());
  const int ns2 = 2 * data.nw;  // signals: Coulomb per width, then Stribeck
  data.profile.assign(static_cast<size_t>(nj), WidthProfileSums{});
  for (WidthProfileSums& pr : data.profile) {
    pr.B = Eigen::MatrixXd::Zero(data.md, ns2 + 1);
    pr.cc = pr.cy = pr.cv = Eigen::VectorXd::Zero(ns2 + 1);
  }
  Eigen::VectorXd sig(ns2 + 1);
  // The elastic profile (with q): signals z [ne + 2] per joint.
  const int ne = static_cast<int>(opt.elastic_scales.size());
  data.q_ref.clear();
  data.eprofile.assign(data.has_q ? static_cast<size_t>(nj) : 0, ElasticProfileSums{});
  for (ElasticProfileSums& pr : data.eprofile) {
    pr.B = Eigen::MatrixXd::Zero(data.md, ne + 2);
    pr.G = Eigen::MatrixXd::Zero(ne + 2, ne + 2);
    pr.zy = Eigen::VectorXd::Zero(ne + 2);
  }
  Eigen::VectorXd z(ne + 2);
  // The coupled-exponential profile: one sum per (joint, kinematic neighbour), signals zc [ns nr + 3].
  const int nzc = static_cast<int>(opt.coupled_elastic_scales.size() * opt.coupled_elastic_ratios.size()) + 3;
  data.cprofile.clear();
  const bool coupled_exp = data.has_q && nzc > 3 &&
                           std::find(opt.kinds.begin(), opt.kinds.end(), EffectKind::ElasticExpCoupled) != opt.kinds.end();
  if (coupled_exp) {
    const std::vector<std::vector<int>> neighbours = kinematicNeighbours(model);
    for (int j = 0; j < nj; ++j)
      for (int c : neighbours[static_cast<size_t>(j)]) {
        CoupledElasticProfileSums pr;
        pr.joint = j, pr.coupled = c;
        pr.B = Eigen::MatrixXd::Zero(data.md, nzc);
        pr.G = Eigen::MatrixXd::Zero(nzc, 4);
        pr.zy = Eigen::VectorXd::Zero(nzc);
        data.cprofile.push_back(std::move(pr));
      }
  }
  Eigen::VectorXd zc(nzc);
  std::string size_error;
  for (size_t s = 0; s < data.ntrain; ++s) {
    SegmentSignals& cache = data.caches[s];
    const Segment& seg = data.segment(s);
    std::vector<double> vs, ys, es, qs;
    const bool ok = streamWithPositions(
        seg, nj, qs, size_error,
        [&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd& tau_sensor) {
          if (K.rows() != nv || K.cols() != data.p || y.size() != nv) {
            size_error = seg.name + ": a sample does not match the model's size";
            return;
          }
          cache.t.push_back(t);
          for (int j = 0; j < nj; ++j) vs.push_back(K(model.jointRow(j), model.frictionParamIndex(j)));
          if (data.nw > 1) addWidthProfile(model, opt, data, s, K, y, sig);
          if (data.has_q) {
            const Eigen::Map<const Eigen::VectorXd> q(qs.data() + qs.size() - nj, nj);
            addElasticProfile(model, opt, data, s, K, y, q, z);
            if (coupled_exp) addCoupledProfile(model, opt, data, s, K, y, q, zc);
          }
          for (int r = 0; r < nv; ++r) ys.push_back(y[r]), es.push_back(y[r] - tau_sensor[r]);
          addDeclaredRows(model, data, K, y);
        },
        error);
    if (!ok) return false;
    if (!size_error.empty()) return common::fail(error, size_error);
    cache.n = static_cast<long>(cache.t.size());
    if (cache.n < 3) return common::fail(error, seg.name + ": fewer than 3 samples");
    cache.v = Eigen::Map<Eigen::MatrixXd>(vs.data(), nj, cache.n).transpose();
    cache.y = Eigen::Map<Eigen::MatrixXd>(ys.data(), nv, cache.n).transpose();
    cache.ext = Eigen::Map<Eigen::MatrixXd>(es.data(), nv, cache.n).transpose();
    out.train_samples += cache.n;
  }
  data.declared_factor.flush();
  return true;
}

bool declaredFit(DiagnoseData& data, DiagnosisResult& out, std::string* error) {
  const int md = data.md, nv = data.nv;
  const Eigen::MatrixXd& R = data.declared_factor.R();
  Eigen::MatrixXd Rs = R.leftCols(md);
  Eigen::VectorXd norms = Rs.colwise().norm().transpose();
  for (int c = 0; c < md; ++c) Rs.col(c) /= norms[c] > 0 ? norms[c] : 1.0;
  std::vector<int>& keep = data.keep;
  keep.clear();
  if (md > 0) {  // (none: a held declared model without friction columns)
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Rs);
    qr.setThreshold(1e-8);
    for (int i = 0; i < qr.rank(); ++i)
      if (norms[qr.colsPermutation().indices()[i]] > 0) keep.push_back(qr.colsPermutation().indices()[i]);
  }
  std::sort(keep.begin(), keep.end());
  if (keep.empty() && md > 0)
    return common::fail(error, "the training data excite none of the declared model's parameters");
  out.dropped_columns = md - static_cast<int>(keep.size());
  std::vector<int> d2;
  std::vector<std::vector<char>> t2(nv);
  for (int c : keep) d2.push_back(data.decl[c]);
  for (int r = 0; r < nv; ++r)
    for (int c : keep) t2[r].push_back(data.touched[r][c]);
  data.A_keep.resize(md + 1, keep.size());
  for (size_t i = 0; i < keep.size(); ++i) data.A_keep.col(i) = R.col(keep[i]);
  data.decl = d2;
  data.touched = t2;
  const int m = data.m = static_cast<int>(data.decl.size());
  data.x0 = m > 0 ? Eigen::VectorXd(data.A_keep.householderQr().solve(R.col(md))) : Eigen::VectorXd();
  out.declared_columns = m;
  if (out.train_samples * nv <= m)
    return common::fail(error, "fewer training rows than declared parameters");
  return true;
}

bool declaredPrediction(const Model& model, DiagnoseData& data, DiagnosisResult& out, std::string* error) {
  const int nv = data.nv, nj = data.nj, m = data.m;
  std::string size_error;
  for (size_t s = 0; s < data.caches.size(); ++s) {
    SegmentSignals& cache = data.caches[s];
    const Segment& seg = data.segment(s);
    const bool is_train = s < data.ntrain;
    std::vector<double> vs, ys, es, taus, qs, bs;
    long i = 0;
    // The base link's own columns of K (docs/conventions.md): the Ixx, Iyy, Izz columns' moment rows are alpha exactly
    // (omega x (I omega) has no component along a principal axis of a one-axis inertia), the m column's force rows s.
    const int b0 = model.floating_base ? model.bodyParamIndex(0) : -1;
    const bool ok = streamWithPositions(
        seg, nj, qs, size_error,
        [&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd& tau_sensor) {
          if (K.rows() != nv || K.cols() != data.p || y.size() != nv) {
            size_error = seg.name + ": a sample does not match the model's size";
            return;
          }
          if (!is_train) {
            cache.t.push_back(t);
            for (int j = 0; j < nj; ++j) vs.push_back(K(model.jointRow(j), model.frictionParamIndex(j)));
            for (int r = 0; r < nv; ++r) ys.push_back(y[r]), es.push_back(y[r] - tau_sensor[r]);
          }
          if (b0 >= 0)
            bs.insert(bs.end(), {K(0, b0 + 4), K(1, b0 + 7), K(2, b0 + 9), K(3, b0), K(4, b0), K(5, b0)});
          for (int r = 0; r < nv; ++r) {
            double pr = 0.0;
            for (int c = 0; c < m; ++c) pr += K(r, data.decl[c]) * data.x0[c];
            taus.push_back(pr);
          }
          ++i;
        },
        error);
    if (!ok) return false;
    if (!size_error.empty()) return common::fail(error, size_error);
    if (!is_train) {
      cache.n = static_cast<long>(cache.t.size());
      if (cache.n < 3) return common::fail(error, seg.name + ": fewer than 3 samples");
      cache.v = Eigen::Map<Eigen::MatrixXd>(vs.data(), nj, cache.n).transpose();
      cache.y = Eigen::Map<Eigen::MatrixXd>(ys.data(), nv, cache.n).transpose();
      cache.ext = Eigen::Map<Eigen::MatrixXd>(es.data(), nv, cache.n).transpose();
      out.validation_samples += cache.n;
    } else if (i != cache.n) {
      return common::fail(error, seg.name + ": the data changed between two reads");
    }
    cache.tau = Eigen::Map<Eigen::MatrixXd>(taus.data(), nv, cache.n).transpose();
    cache.tau0 = cache.tau;
    cache.q = qs.size() == static_cast<size_t>(cache.n * nj)
                  ? Eigen::MatrixXd(Eigen::Map<Eigen::MatrixXd>(qs.data(), nj, cache.n).transpose())
                  : Eigen::MatrixXd();
    cache.base = bs.size() == static_cast<size_t>(cache.n * 6)
                     ? Eigen::MatrixXd(Eigen::Map<Eigen::MatrixXd>(bs.data(), 6, cache.n).transpose())
                     : Eigen::MatrixXd();
    cache.a = centralDifference(cache.t, cache.v);
    cache.dext = centralDifference(cache.t, cache.ext);
    cache.dtau = centralDifference(cache.t, cache.tau);
  }
  return true;
}

void rowWeights(const Model& model, DiagnoseData& data) {
  const int nv = data.nv;
  Eigen::VectorXd sse0 = Eigen::VectorXd::Zero(nv);
  data.rows0 = Eigen::VectorXd::Zero(nv);
  for (size_t s = 0; s < data.ntrain; ++s) {
    sse0 += (data.caches[s].y - data.caches[s].tau0).colwise().squaredNorm().transpose();
    for (int r = 0; r < nv; ++r) data.rows0[r] += data.unmeasured(model, s, r) ? 0.0 : static_cast<double>(data.caches[s].n);
  }
  data.sigma = (sse0.array() / data.rows0.array().max(1.0)).sqrt().matrix();
  const double smax = data.sigma.maxCoeff();
  for (int r = 0; r < nv; ++r) data.sigma[r] = std::max(data.sigma[r], 1e-9 * smax + 1e-300);
  data.total_rows = static_cast<long>(data.rows0.sum());  // measured rows (held-base segments: no base rows)
}

}  // namespace exoid::estimator
