#include "exoid/estimator/diagnose.hpp"

#include <yaml-cpp/yaml.h>

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>

#include "exoid/estimator/base_parameters.hpp"

namespace exoid::estimator {

namespace {
constexpr const char* kNames[kEffectKinds] = {"viscous", "coulomb", "stribeck", "offset", "armature", "gain", "delay"};
constexpr const char* kWords[kEffectKinds] = {"viscous friction",     "Coulomb friction", "Stribeck friction (static excess)",
                                              "constant torque offset", "armature (rotor inertia)",
                                              "torque-sensor gain error", "time delay of the torque"};
constexpr const char* kUnits[kEffectKinds] = {"N m s/rad", "N m", "N m", "N m", "kg m^2", "", "s"};
}  // namespace

const char* effectKindName(EffectKind k) { return kNames[static_cast<int>(k)]; }
const char* effectKindWords(EffectKind k) { return kWords[static_cast<int>(k)]; }
const char* effectUnit(EffectKind k) { return kUnits[static_cast<int>(k)]; }
bool parseEffectKind(const std::string& name, EffectKind& k) {
  for (int i = 0; i < kEffectKinds; ++i)
    if (name == kNames[i]) return k = static_cast<EffectKind>(i), true;
  return false;
}
bool isMeasurementEffect(EffectKind k) { return k == EffectKind::GainError || k == EffectKind::Delay; }
bool isDryFriction(EffectKind k) { return k == EffectKind::Coulomb || k == EffectKind::Stribeck; }
bool admissibleValue(EffectKind k, double value) {
  switch (k) {
    case EffectKind::Viscous:
    case EffectKind::Coulomb:
    case EffectKind::Stribeck:
    case EffectKind::Armature:
      return value >= 0.0;
    default:
      return true;
  }
}

EffectShape effectShape(const EffectShape& shape, const Effect& effect) {
  EffectShape s = shape;
  if (effect.width > 0.0 && isDryFriction(effect.kind))
    s.coulomb_width = effect.width;
  return s;
}

double effectSignal(EffectKind k, const EffectShape& shape, double v, double a, double tau_model, double dtau_model) {
  switch (k) {
    case EffectKind::Viscous: return v;
    case EffectKind::Coulomb: return std::tanh(v / shape.coulomb_width);
    case EffectKind::Stribeck: {
      const double r = v / shape.stribeck_velocity;
      return std::tanh(v / shape.coulomb_width) * std::exp(-r * r);
    }
    case EffectKind::Offset: return 1.0;
    case EffectKind::Armature: return a;
    case EffectKind::GainError: return tau_model;
    case EffectKind::Delay: return -dtau_model;
  }
  return 0.0;
}

// ---------------------------------------------------------------------------------------------------------
// Student's t tail through the regularised incomplete beta function (continued fraction, Lentz).
namespace {
double betaContinuedFraction(double a, double b, double x) {
  const double tiny = 1e-300;
  double c = 1.0, d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::fabs(d) < tiny) d = tiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m <= 300; ++m) {
    const double m2 = 2.0 * m;
    double aa = m * (b - m) * x / ((a + m2 - 1.0) * (a + m2));
    d = 1.0 + aa * d;
    if (std::fabs(d) < tiny) d = tiny;
    c = 1.0 + aa / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    h *= d * c;
    aa = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1.0));
    d = 1.0 + aa * d;
    if (std::fabs(d) < tiny) d = tiny;
    c = 1.0 + aa / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::fabs(del - 1.0) < 1e-15) break;
  }
  return h;
}
// I_x(a, b)
double incompleteBeta(double a, double b, double x) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  const double lbt = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  if (x < (a + 1.0) / (a + b + 2.0)) return std::exp(lbt) * betaContinuedFraction(a, b, x) / a;
  return 1.0 - std::exp(lbt) * betaContinuedFraction(b, a, 1.0 - x) / b;
}
}  // namespace

double studentTUpperTail(double t, double dof) {
  if (std::isnan(t)) return 1.0;
  if (std::isinf(t)) return t > 0 ? 0.0 : 1.0;
  const double tail = 0.5 * incompleteBeta(0.5 * dof, 0.5, dof / (dof + t * t));  // P(T >= |t|)
  return t >= 0.0 ? tail : 1.0 - tail;
}

// ---------------------------------------------------------------------------------------------------------
namespace {

// Upper-triangular factor R [n x n] of rows streamed in blocks: ||A x||^2 = ||R x||^2 for every x.
class TriFactor {
 public:
  explicit TriFactor(int n = 0, int block = 0) { reset(n, block); }
  void reset(int n, int block) {
    n_ = n;
    block_ = block > 0 ? block : std::max(64, 2 * n);
    R_ = Eigen::MatrixXd::Zero(n, n);
    buf_.resize(0, 0);
    nbuf_ = 0;
  }
  // Row pointer to fill (n entries), committed at once.
  Eigen::Ref<Eigen::RowVectorXd> nextRow() {
    if (buf_.rows() == 0) buf_ = RowMajor::Zero(block_, n_);
    if (nbuf_ == block_) flush();
    return buf_.row(nbuf_++);
  }
  void flush() {
    if (nbuf_ == 0) return;
    Eigen::MatrixXd stack(n_ + nbuf_, n_);
    stack << R_, buf_.topRows(nbuf_);
    R_ = triangular(stack);
    nbuf_ = 0;
  }
  const Eigen::MatrixXd& R() const { return R_; }
  static Eigen::MatrixXd triangular(const Eigen::MatrixXd& stack) {
    const int n = static_cast<int>(stack.cols());
    Eigen::MatrixXd R = Eigen::MatrixXd::Zero(n, n);
    if (stack.rows() == 0) return R;
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(stack);
    const int k = static_cast<int>(std::min<Eigen::Index>(stack.rows(), n));
    R.topRows(k) = qr.matrixQR().topRows(k).triangularView<Eigen::Upper>();
    return R;
  }

 private:
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  int n_ = 0, block_ = 64, nbuf_ = 0;
  Eigen::MatrixXd R_;
  RowMajor buf_;
};

struct Candidate {
  EffectKind kind;
  int joint;
  int coord;
  double width;  // Coulomb, Stribeck: the joint's profiled width (0: the shape's)
};

// Per-sample signals of one segment.
struct Cache {
  long n = 0;
  std::vector<double> t;
  Eigen::MatrixXd ext, dext;  // [n x nv] y minus the torque sensors' part (the plates' contribution), d/dt of it
  Eigen::MatrixXd v, a, y, tau0, tau, dtau;  // [n x nj], [n x nj], [n x nv], declared prediction [n x nv],
                                             // reference prediction of the gain/delay signals [n x nv], d/dt of it
};

// Central differences of the columns of x over (possibly jittering) times t; one-sided at the ends.
Eigen::MatrixXd derivative(const std::vector<double>& t, const Eigen::MatrixXd& x) {
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

double lag1(const Eigen::VectorXd& r) {
  if (r.size() < 3) return 0.0;
  const Eigen::VectorXd c = r.array() - r.mean();
  const double den = c.squaredNorm();
  return den > 0 ? c.head(c.size() - 1).dot(c.tail(c.size() - 1)) / den : 0.0;
}

double correlation(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const Eigen::VectorXd x = a.array() - a.mean(), y = b.array() - b.mean();
  const double den = std::sqrt(x.squaredNorm() * y.squaredNorm());
  return den > 0 ? x.dot(y) / den : 0.0;
}

std::string formatValue(EffectKind k, double value, double se) {
  char buf[160];
  if (k == EffectKind::GainError)
    std::snprintf(buf, sizeof buf, "%+.2f %% (+- %.2f)", 100.0 * value, 100.0 * se);
  else if (k == EffectKind::Delay)
    std::snprintf(buf, sizeof buf, "%+.2f ms (+- %.2f)", 1e3 * value, 1e3 * se);
  else
    std::snprintf(buf, sizeof buf, "%.3g %s (+- %.2g)", value, effectUnit(k), se);
  return buf;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------
bool diagnose(const Model& model, const std::vector<Segment>& train, const std::vector<Segment>& validate,
              const DiagnoseOptions& opt, DiagnosisResult& out, std::string* error) {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (train.empty()) return fail("no training data");
  if (opt.folds < 3) return fail("at least 3 folds are needed for the held-out test");
  if (!(opt.shape.coulomb_width > 0) || !(opt.shape.stribeck_velocity > 0))
    return fail("the Coulomb width and the Stribeck velocity must be positive");
  out = DiagnosisResult{};
  const int nv = model.nv, nj = model.njoints, p = model.nparams();
  for (int r = 0; r < nv; ++r) {
    static const char* kBase[6] = {"base_nx", "base_ny", "base_nz", "base_fx", "base_fy", "base_fz"};
    out.coordinate_names.push_back(model.floating_base && r < 6 ? kBase[r] : model.joint_names[r - (model.floating_base ? 6 : 0)]);
  }

  // Declared columns: the structural base parameters, without the friction columns unless declared.
  const BaseParameters base = computeBaseParameters(model);
  std::vector<int> decl;
  for (int c : base.independent)
    if ((opt.declared_friction || c < model.nInertialParams()) && !(opt.hold_declared && c < model.nInertialParams()))
      decl.push_back(c);  // held rigid-body parameters: the caller took K phi_declared off y
  std::sort(decl.begin(), decl.end());
  const int md = static_cast<int>(decl.size());
  // Payload candidates: per moving link, its m, mcx, mcy, mcz columns of K (held declared model only: an identified
  // link absorbs a payload). ptouch[r][l]: row r can see link l's payload.
  std::vector<int> plinks;
  for (int b = 0; opt.payload && opt.hold_declared && b < model.nbodies; ++b) plinks.push_back(b);
  const int npl = static_cast<int>(plinks.size());
  std::vector<std::vector<char>> ptouch(nv, std::vector<char>(static_cast<size_t>(npl), 0));

  std::vector<Cache> caches(train.size() + validate.size());
  auto segment = [&](size_t i) -> const Segment& { return i < train.size() ? train[i] : validate[i - train.size()]; };
  // Segment::held_base: that segment's unmeasured rows are zero rows (K, y and every candidate signal), not data.
  auto unmeasured = [&](size_t s, int r) { return !segmentRowMeasured(model, segment(s), r); };
  auto bad_size = [&](const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
    return K.rows() != nv || K.cols() != p || y.size() != nv;
  };

  // Pass A (training): factor of [K_decl | y], the excitation of every (coordinate, column), t, v, y; and per
  // joint the sums of the width profile (below): K_j^T s, s^T s, s^T y_j (K_j: the joint's row of the declared
  // columns) for the Coulomb and Stribeck signals s_w of every width w of the grid and for v, and s_w^T v.
  TriFactor fa(md + 1);
  const std::vector<double> widths =
      opt.coulomb_widths.empty() ? std::vector<double>{opt.shape.coulomb_width} : opt.coulomb_widths;
  const int nw = static_cast<int>(widths.size()), ns2 = 2 * nw;  // signals: Coulomb per width, then Stribeck
  struct Profile {
    Eigen::MatrixXd B;  // [md x (ns2 + 1)]
    Eigen::VectorXd cc, cy, cv;  // [ns2 + 1], [ns2 + 1], [ns2 + 1]
  };
  std::vector<Profile> prof(static_cast<size_t>(nj));
  for (Profile& pr : prof) {
    pr.B = Eigen::MatrixXd::Zero(md, ns2 + 1);
    pr.cc = pr.cy = pr.cv = Eigen::VectorXd::Zero(ns2 + 1);
  }
  Eigen::VectorXd sig(ns2 + 1);
  std::vector<std::vector<char>> touched(nv, std::vector<char>(md, 0));
  std::string size_error;
  for (size_t s = 0; s < train.size(); ++s) {
    Cache& cache = caches[s];
    std::vector<double> vs, ys, es;
    const bool ok = train[s].stream(
        [&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd& tau_sensor) {
          if (bad_size(K, y)) {
            size_error = train[s].name + ": a sample does not match the model's size";
            return;
          }
          cache.t.push_back(t);
          for (int j = 0; j < nj; ++j) vs.push_back(K(model.jointRow(j), model.frictionParamIndex(j)));
          if (nw > 1)
            for (int j = 0; j < nj; ++j) {
              const int r = model.jointRow(j);
              if (unmeasured(s, r)) continue;
              const double v = K(r, model.frictionParamIndex(j));
              for (int w = 0; w < nw; ++w) {
                EffectShape sh = opt.shape;
                sh.coulomb_width = widths[w];
                sig[w] = effectSignal(EffectKind::Coulomb, sh, v, 0.0, 0.0, 0.0);
                sig[nw + w] = effectSignal(EffectKind::Stribeck, sh, v, 0.0, 0.0, 0.0);
              }
              sig[ns2] = v;
              Profile& pr = prof[static_cast<size_t>(j)];
              for (int c = 0; c < md; ++c)
                if (const double k = K(r, decl[c]); k != 0.0) pr.B.row(c) += k * sig.transpose();
              pr.cc += sig.cwiseAbs2();
              pr.cy += y[r] * sig;
              pr.cv += v * sig;
            }
          for (int r = 0; r < nv; ++r) {
            ys.push_back(y[r]);
            es.push_back(y[r] - tau_sensor[r]);
            auto row = fa.nextRow();
            for (int c = 0; c < md; ++c) {
              row[c] = K(r, decl[c]);
              if (row[c] != 0.0) touched[r][c] = 1;
            }
            row[md] = y[r];
            for (int l = 0; l < npl; ++l)
              for (int k = 0; k < 4 && !ptouch[r][l]; ++k)
                if (K(r, model.bodyParamIndex(plinks[l]) + k) != 0.0) ptouch[r][l] = 1;
          }
        },
        error);
    if (!ok) return false;
    if (!size_error.empty()) return fail(size_error);
    cache.n = static_cast<long>(cache.t.size());
    if (cache.n < 3) return fail(train[s].name + ": fewer than 3 samples");
    cache.v = Eigen::Map<Eigen::MatrixXd>(vs.data(), nj, cache.n).transpose();
    cache.y = Eigen::Map<Eigen::MatrixXd>(ys.data(), nv, cache.n).transpose();
    cache.ext = Eigen::Map<Eigen::MatrixXd>(es.data(), nv, cache.n).transpose();
    out.train_samples += cache.n;
  }
  fa.flush();
  std::vector<double> width_of;  // [2 nj] the profiled Coulomb width of each joint's Coulomb, Stribeck candidates

  // Excited declared columns (column-pivoted QR of the unit-norm columns), then the declared OLS fit.
  {
    Eigen::MatrixXd Rs = fa.R().leftCols(md);
    Eigen::VectorXd norms = Rs.colwise().norm().transpose();
    for (int c = 0; c < md; ++c) Rs.col(c) /= norms[c] > 0 ? norms[c] : 1.0;
    std::vector<int> keep;
    if (md > 0) {  // (none: a held declared model without friction columns)
      Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Rs);
      qr.setThreshold(1e-8);
      for (int i = 0; i < qr.rank(); ++i)
        if (norms[qr.colsPermutation().indices()[i]] > 0) keep.push_back(qr.colsPermutation().indices()[i]);
    }
    std::sort(keep.begin(), keep.end());
    if (keep.empty() && md > 0) return fail("the training data excite none of the declared model's parameters");
    out.dropped_columns = md - static_cast<int>(keep.size());
    std::vector<int> d2;
    std::vector<std::vector<char>> t2(nv);
    for (int c : keep) d2.push_back(decl[c]);
    for (int r = 0; r < nv; ++r)
      for (int c : keep) t2[r].push_back(touched[r][c]);
    Eigen::MatrixXd A(md + 1, keep.size());
    for (size_t i = 0; i < keep.size(); ++i) A.col(i) = fa.R().col(keep[i]);
    decl = d2;
    touched = t2;
    const int m = static_cast<int>(decl.size());
    const Eigen::VectorXd x0 = m > 0 ? Eigen::VectorXd(A.householderQr().solve(fa.R().col(md))) : Eigen::VectorXd();
    out.declared_columns = m;
    // Width profile: per joint and dry-friction kind, the width whose signal s, together with the viscous signal v
    // (on the joint's row), would remove the most of the declared fit's training residual e: the least-squares
    // gain g^T M^-1 g of the two columns made orthogonal to the declared columns of every row (their Gram from the
    // factor above), M their Gram, g their products with e. e is orthogonal to the declared columns, so
    // s_perp . e = s . e. With v beside it, a wide tanh gains nothing by imitating viscous friction: the width
    // describes the dry part (alone, the KUKA's joints all took the grid's widest). Every width in one pass.
    width_of.assign(static_cast<size_t>(2 * nj), widths[0]);  // the one width; with a grid, overwritten below
    if (nw > 1) {
      // The declared (kept) columns' Gram is A^T A (A: their columns of the factor); R1^T R1 with R1 from its QR.
      const int mk = static_cast<int>(keep.size());
      const Eigen::MatrixXd R1 =
          mk > 0 ? Eigen::MatrixXd(A.householderQr().matrixQR().topRows(mk).triangularView<Eigen::Upper>()) : Eigen::MatrixXd();
      for (int j = 0; j < nj; ++j) {
        const Profile& pr = prof[static_cast<size_t>(j)];
        Eigen::MatrixXd B(mk, ns2 + 1);
        for (int a = 0; a < mk; ++a) B.row(a) = pr.B.row(keep[a]);
        // Projections on the declared span: s_a^T P s_b = Z_a . Z_b with R1^T Z = B.
        const Eigen::MatrixXd Z = mk > 0 ? Eigen::MatrixXd(R1.transpose().triangularView<Eigen::Lower>().solve(B))
                                         : Eigen::MatrixXd::Zero(0, ns2 + 1);
        const Eigen::VectorXd se = mk > 0 ? Eigen::VectorXd(pr.cy - B.transpose() * x0) : pr.cy;  // s^T e (and v^T e last)
        const double vv = pr.cc[ns2] - Z.col(ns2).squaredNorm();
        for (int kind = 0; kind < 2; ++kind) {
          double best = -1.0;
          for (int w = 0; w < nw; ++w) {
            const int s = kind * nw + w;
            const double ss = pr.cc[s] - Z.col(s).squaredNorm(), sv = pr.cv[s] - Z.col(s).dot(Z.col(ns2));
            const double det = ss * vv - sv * sv;
            double score = 0.0;
            if (det > 1e-12 * ss * vv)  // [s v] gain: g^T M^-1 g
              score = (vv * se[s] * se[s] - 2.0 * sv * se[s] * se[ns2] + ss * se[ns2] * se[ns2]) / det;
            else if (ss > 1e-12 * pr.cc[s])
              score = se[s] * se[s] / ss;
            if (score > best) best = score, width_of[static_cast<size_t>(2 * j + kind)] = widths[w];
          }
        }
      }
    }
    if (out.train_samples * nv <= m) return fail("fewer training rows than declared parameters");

    // Pass B (every segment): the declared model's prediction; the validation segments' t, v, y.
    for (size_t s = 0; s < caches.size(); ++s) {
      Cache& cache = caches[s];
      const bool is_train = s < train.size();
      std::vector<double> vs, ys, es, taus;
      long i = 0;
      const bool ok = segment(s).stream(
          [&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd& tau_sensor) {
            if (bad_size(K, y)) {
              size_error = segment(s).name + ": a sample does not match the model's size";
              return;
            }
            if (!is_train) {
              cache.t.push_back(t);
              for (int j = 0; j < nj; ++j) vs.push_back(K(model.jointRow(j), model.frictionParamIndex(j)));
              for (int r = 0; r < nv; ++r) ys.push_back(y[r]), es.push_back(y[r] - tau_sensor[r]);
            }
            for (int r = 0; r < nv; ++r) {
              double pr = 0.0;
              for (int c = 0; c < m; ++c) pr += K(r, decl[c]) * x0[c];
              taus.push_back(pr);
            }
            ++i;
          },
          error);
      if (!ok) return false;
      if (!size_error.empty()) return fail(size_error);
      if (!is_train) {
        cache.n = static_cast<long>(cache.t.size());
        if (cache.n < 3) return fail(segment(s).name + ": fewer than 3 samples");
        cache.v = Eigen::Map<Eigen::MatrixXd>(vs.data(), nj, cache.n).transpose();
        cache.y = Eigen::Map<Eigen::MatrixXd>(ys.data(), nv, cache.n).transpose();
        cache.ext = Eigen::Map<Eigen::MatrixXd>(es.data(), nv, cache.n).transpose();
        out.validation_samples += cache.n;
      } else if (i != cache.n) {
        return fail(segment(s).name + ": the data changed between two reads");
      }
      cache.tau = Eigen::Map<Eigen::MatrixXd>(taus.data(), nv, cache.n).transpose();
      cache.tau0 = cache.tau;
      cache.a = derivative(cache.t, cache.v);
      cache.dext = derivative(cache.t, cache.ext);
      cache.dtau = derivative(cache.t, cache.tau);
    }

    // Row weights 1 / sigma_c from the declared model's training residual (WLS-R, thesis eqs. 29-32), so
    // that the test pools coordinates of very different torque scales fairly.
    Eigen::VectorXd sse0 = Eigen::VectorXd::Zero(nv), rows0 = Eigen::VectorXd::Zero(nv);
    for (size_t s = 0; s < train.size(); ++s) {
      sse0 += (caches[s].y - caches[s].tau0).colwise().squaredNorm().transpose();
      for (int r = 0; r < nv; ++r) rows0[r] += unmeasured(s, r) ? 0.0 : static_cast<double>(caches[s].n);
    }
    Eigen::VectorXd sigma = (sse0.array() / rows0.array().max(1.0)).sqrt().matrix();
    const double smax = sigma.maxCoeff();
    for (int r = 0; r < nv; ++r) sigma[r] = std::max(sigma[r], 1e-9 * smax + 1e-300);

    // Candidate columns.
    std::vector<Candidate> cands;
    for (EffectKind k : opt.kinds)
      for (int j = 0; j < nj; ++j) {
        const int r = model.jointRow(j);
        if (opt.declared_friction && (k == EffectKind::Viscous || k == EffectKind::Coulomb)) continue;
        bool measured = false;
        for (size_t s = 0; s < train.size(); ++s) measured = measured || caches[s].y.col(r).cwiseAbs().maxCoeff() > 0;
        // A gain error needs a torque sensor: a measured torque and an actuated joint (URDF effort > 0).
        const bool sensed = measured && (model.effort_limit.size() != nj || model.effort_limit[j] > 0);
        if (k == EffectKind::GainError && !sensed) continue;
        cands.push_back({k, j, r, isDryFriction(k) ? width_of[static_cast<size_t>(2 * j + (k == EffectKind::Stribeck))] : 0.0});
      }
    const int nc = static_cast<int>(cands.size());
    out.candidates = nc;
    const int P = m + nc + 4 * npl + 1, iy = P - 1;  // columns: declared, candidates, payloads (4 per link), y
    const int pc0 = m + nc;                              // the first payload column
    auto payloadParam = [&](int c) { return model.bodyParamIndex(plinks[(c - pc0) / 4]) + (c - pc0) % 4; };
    auto signal = [&](size_t s, long i, const Candidate& cd) {  // s: the segment (cache) index
      if (unmeasured(s, cd.coord)) return 0.0;
      const Cache& c = caches[s];
      // Gain and delay act on the torque sensor only: the model's prediction of the sensor's part of y (y minus
      // what the plates contribute; all of y for a fixed base).
      return effectSignal(cd.kind, effectShape(opt.shape, Effect{cd.kind, cd.joint, 0.0, cd.width}), c.v(i, cd.joint),
                          c.a(i, cd.joint), c.tau(i, cd.coord) - c.ext(i, cd.coord),
                          c.dtau(i, cd.coord) - c.dext(i, cd.coord));
    };

    // Active columns (P-space) of each coordinate and the map back.
    std::vector<std::vector<int>> active(nv);
    for (int r = 0; r < nv; ++r) {
      for (int c = 0; c < m; ++c)
        if (touched[r][c]) active[r].push_back(c);
      for (int c = 0; c < nc; ++c)
        if (cands[c].coord == r) active[r].push_back(m + c);
      for (int l = 0; l < npl; ++l)
        if (ptouch[r][l])
          for (int k = 0; k < 4; ++k) active[r].push_back(pc0 + 4 * l + k);
      active[r].push_back(iy);
    }

    // The gain and delay signals are linearised about a reference prediction (first the declared model's);
    // when they are chosen, Gauss-Newton: the reference becomes the augmented model's rigid part and the
    // accepted set is refitted, until the values settle (the selection itself is made once).
    std::vector<int> S(m);
    for (int c = 0; c < m; ++c) S[c] = c;
    Eigen::VectorXd xa;
    const int F = opt.folds;
    std::vector<TriFactor> fc(static_cast<size_t>(F) * nv);
    std::vector<int> fcol, pcol;  // P-space column of each accepted effect; first column of each accepted payload
    std::vector<char> pdone(static_cast<size_t>(npl), 0);  // payload candidates accepted or not testable
    // The selection runs in the first pass and, after a payload is accepted while gain or delay candidates are
    // tested, goes on in the next one, whose signals are linearised about the model with the payload.
    bool selecting = true, relinearise = false;
    int steps_done = 0;
    bool measurement_cands = false;
    for (const Candidate& cd : cands) measurement_cands = measurement_cands || isMeasurementEffect(cd.kind);
    // R^-1 B for an upper-triangular R that may be empty (no column in the model yet).
    auto usolve = [](const Eigen::MatrixXd& R, const Eigen::MatrixXd& B) -> Eigen::MatrixXd {
      if (R.rows() == 0) return Eigen::MatrixXd::Zero(0, B.cols());
      return R.triangularView<Eigen::Upper>().solve(B);
    };
    auto posOf = [&](int col) { return static_cast<int>(std::find(S.begin(), S.end(), col) - S.begin()); };
    for (int gn = 0;; ++gn) {
    // Pass C (training, from the caches and one more read of K): per-(fold, coordinate) factors of the
    // weighted rows [K_decl | candidates | y] / sigma_c over the active columns.
    for (int f = 0; f < F; ++f)
      for (int r = 0; r < nv; ++r) fc[f * nv + r].reset(static_cast<int>(active[r].size()), 0);
    for (size_t s = 0; s < train.size(); ++s) {
      const Cache& cache = caches[s];
      long i = 0;
      const bool ok = train[s].stream(
          [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd&) {
            if (i >= cache.n) return;
            const int f = static_cast<int>(static_cast<long>((cache.t[i] - cache.t[0]) / opt.chunk_seconds) % F);
            for (int r = 0; r < nv; ++r) {
              auto row = fc[f * nv + r].nextRow();
              const std::vector<int>& act = active[r];
              for (size_t k = 0; k < act.size(); ++k) {
                const int c = act[k];
                const double val = c < m ? K(r, decl[c]) : c < pc0 ? signal(s, i, cands[c - m]) : c < iy ? K(r, payloadParam(c)) : y[r];
                row[k] = val / sigma[r];
              }
            }
            ++i;
          },
          error);
      if (!ok) return false;
      if (i != cache.n) return fail(train[s].name + ": the data changed between two reads");
    }
    for (TriFactor& t : fc) t.flush();

    // Scatter the coordinate factors into P-space: per fold, training-without-fold, all; unweighted all.
    auto merge = [&](const std::vector<std::pair<int, int>>& which, bool unweight) {
      long rows = 0;
      for (auto& fr : which) rows += static_cast<long>(active[fr.second].size());
      Eigen::MatrixXd stack = Eigen::MatrixXd::Zero(rows, P);
      long at = 0;
      for (auto& fr : which) {
        const std::vector<int>& act = active[fr.second];
        const Eigen::MatrixXd& R = fc[fr.first * nv + fr.second].R();
        const double scale = unweight ? sigma[fr.second] : 1.0;
        for (size_t k = 0; k < act.size(); ++k) stack.block(at, act[k], act.size(), 1) = scale * R.col(k);
        at += static_cast<long>(act.size());
      }
      return TriFactor::triangular(stack);
    };
    std::vector<Eigen::MatrixXd> Rfold(F), Rtrain(F + 1);
    for (int f = 0; f < F; ++f) {
      std::vector<std::pair<int, int>> w;
      for (int r = 0; r < nv; ++r) w.push_back({f, r});
      Rfold[f] = merge(w, false);
    }
    for (int f = 0; f <= F; ++f) {
      Eigen::MatrixXd stack((f < F ? F - 1 : F) * P, P);
      long at = 0;
      for (int g = 0; g < F; ++g)
        if (g != f) stack.middleRows(at, P) = Rfold[g], at += P;
      Rtrain[f] = TriFactor::triangular(stack);  // Rtrain[F]: all training data
    }

    // Forward selection.
    std::vector<char> excluded(nc, 0);
    auto heldout_sse = [&](int f, int r, const Eigen::VectorXd& xP) {  // xP: [P], xP[iy] = -1
      const std::vector<int>& act = active[r];
      Eigen::VectorXd xa(act.size());
      for (size_t k = 0; k < act.size(); ++k) xa[k] = xP[act[k]];
      return (fc[f * nv + r].R() * xa).squaredNorm();
    };
    const long total_rows = static_cast<long>(rows0.sum());  // measured rows (held-base segments: no base rows)
    for (int step = steps_done; selecting && step < opt.max_effects; ++step) {
      steps_done = step + 1;
      const int ns = static_cast<int>(S.size());
      // Per factor (folds, then all): QR of the current columns, the solution and the residual of y.
      std::vector<Eigen::MatrixXd> Q(F + 1), Rs(F + 1), A(F + 1);
      std::vector<Eigen::VectorXd> xs(F + 1), ry(F + 1);
      for (int f = 0; f <= F; ++f) {
        A[f].resize(P, ns);
        for (int k = 0; k < ns; ++k) A[f].col(k) = Rtrain[f].col(S[k]);
        Eigen::HouseholderQR<Eigen::MatrixXd> qr(A[f]);
        Q[f] = qr.householderQ() * Eigen::MatrixXd::Identity(P, ns);
        Rs[f] = qr.matrixQR().topRows(ns).triangularView<Eigen::Upper>();
        const Eigen::VectorXd b = Rtrain[f].col(iy);
        xs[f] = Rs[f].triangularView<Eigen::Upper>().solve(Q[f].transpose() * b);
        ry[f] = b - A[f] * xs[f];
      }
      // Held-out SSE of the current model per (fold, coordinate).
      Eigen::MatrixXd sse_now(F, nv);
      for (int f = 0; f < F; ++f) {
        Eigen::VectorXd xP = Eigen::VectorXd::Zero(P);
        for (int k = 0; k < ns; ++k) xP[S[k]] = xs[f][k];
        xP[iy] = -1.0;
        for (int r = 0; r < nv; ++r) sse_now(f, r) = heldout_sse(f, r, xP);
      }
      const double dof_res = static_cast<double>(total_rows - ns - 1);
      struct Eval {
        int c;
        double gain;
        bool admissible;
        double separable;  // fraction of the column outside the declared (and accepted) columns' span
        double jackknife_se;  // standard error of the value over the folds
        Finding f;
      };
      std::vector<Eval> evals;
      for (int c = 0; c < nc; ++c) {
        if (excluded[c] || std::find(S.begin(), S.end(), m + c) != S.end()) continue;
        const Candidate& cd = cands[c];
        // Training-all estimate and separability.
        const Eigen::VectorXd col = Rtrain[F].col(m + c);
        const Eigen::VectorXd w = Rs[F].triangularView<Eigen::Upper>().solve(Q[F].transpose() * col);
        const Eigen::VectorXd rc = col - A[F] * w;
        const double nrc = rc.squaredNorm();
        if (col.squaredNorm() == 0.0 || !(nrc > 1e-6 * col.squaredNorm())) {
          excluded[c] = 1;
          if (step == 0) {
            CandidateScore sc;
            sc.effect = {cd.kind, cd.joint, 0.0, cd.width};
            sc.separable = col.squaredNorm() > 0.0 ? nrc / col.squaredNorm() : 0.0;
            sc.std_error = INFINITY;
            sc.status = "not separable from the declared model";
            out.first_step.push_back(sc);
          }
          continue;
        }
        const double beta = rc.dot(ry[F]) / nrc;
        const double sse_all = ry[F].squaredNorm() - beta * beta * nrc;
        // Held-out folds: refit on the other folds with the candidate, score on this one.
        Eigen::VectorXd d(F), bfold(F);
        double num = 0.0, den = 0.0;
        for (int f = 0; f < F; ++f) {
          const Eigen::VectorXd colf = Rtrain[f].col(m + c);
          const Eigen::VectorXd wf = Rs[f].triangularView<Eigen::Upper>().solve(Q[f].transpose() * colf);
          const Eigen::VectorXd rcf = colf - A[f] * wf;
          const double nf = rcf.squaredNorm();
          const double bf = nf > 0 ? rcf.dot(ry[f]) / nf : 0.0;
          bfold[f] = bf;
          Eigen::VectorXd xP = Eigen::VectorXd::Zero(P);
          for (int k = 0; k < ns; ++k) xP[S[k]] = xs[f][k] - bf * wf[k];
          xP[m + c] = bf;
          xP[iy] = -1.0;
          d[f] = 0.0;
          for (int r = 0; r < nv; ++r) {
            const double sn = heldout_sse(f, r, xP);
            d[f] += sse_now(f, r) - sn;
            if (r == cd.coord) num += sse_now(f, r) - sn, den += sse_now(f, r);
          }
        }
        // One-sided paired t-test over the folds of the pooled (weighted) held-out squared-error reduction.
        const double mean = d.mean();
        const double sd = std::sqrt((d.array() - mean).square().sum() / (F - 1));
        Eval ev;
        ev.c = c;
        ev.gain = mean;
        ev.admissible = admissibleValue(cd.kind, beta);
        ev.separable = nrc / col.squaredNorm();
        // Delete-one-fold jackknife of the value: the time-block folds keep the residual's correlation (filtered
        // data: the white-noise error below is ~10x optimistic at 5 Hz) out of it.
        ev.jackknife_se = std::sqrt((F - 1.0) / F * (bfold.array() - bfold.mean()).square().sum());
        ev.f.effect = {cd.kind, cd.joint, beta, cd.width};
        ev.f.std_error = std::sqrt(std::max(sse_all, 0.0) / std::max(dof_res, 1.0) / nrc);
        ev.f.explained = den > 0 ? num / den : 0.0;
        ev.f.t_stat = sd > 0 ? mean / (sd / std::sqrt(static_cast<double>(F))) : (mean > 0 ? INFINITY : 0.0);
        ev.f.p_value = studentTUpperTail(ev.f.t_stat, F - 1);
        if (std::getenv("EXOID_DIAGNOSE_DEBUG"))
          std::fprintf(stderr, "step %d %s j%d beta %.4g gain %.4g t %.4g p %.3g expl %.3f\n", step, effectKindName(cd.kind),
                       cd.joint, beta, mean, ev.f.t_stat, ev.f.p_value, ev.f.explained);
        evals.push_back(ev);
      }
      // Payload candidates: a link's 4 columns (m, m c) at once, a rank-4 update of the current fit, tested like the
      // single columns (docs/diagnose.md "Payload").
      struct PayloadEval {
        int l;
        double gain;
        bool admissible;
        PayloadFinding f;
      };
      std::vector<PayloadEval> pevals;
      for (int l = 0; l < npl; ++l) {
        if (pdone[static_cast<size_t>(l)]) continue;
        const int c0 = pc0 + 4 * l;
        PayloadFinding pf;
        pf.link = plinks[l];
        const Eigen::MatrixXd C = Rtrain[F].middleCols(c0, 4);
        const Eigen::Vector4d cn = C.colwise().norm().transpose();
        const Eigen::MatrixXd Wc = usolve(Rs[F], Q[F].transpose() * C);
        const Eigen::MatrixXd Rc = C - A[F] * Wc;
        // Separable share: the smallest |Rc x|^2 / |C x|^2 over the directions x (C = U S V^T, x = V S^-1 z).
        Eigen::JacobiSVD<Eigen::MatrixXd> svc(C, Eigen::ComputeThinV);
        const Eigen::VectorXd sc = svc.singularValues();
        const bool moves = cn.minCoeff() > 0.0 && sc[3] > 1e-7 * sc[0];
        if (moves) {
          const Eigen::MatrixXd M = Rc * svc.matrixV() * sc.cwiseInverse().asDiagonal();
          const double smin = Eigen::JacobiSVD<Eigen::MatrixXd>(M).singularValues()[3];
          pf.separable = smin * smin;
        }
        if (!moves || !(pf.separable > opt.payload_min_separable)) {
          pdone[static_cast<size_t>(l)] = 1;
          if (step == 0) {
            pf.status = !moves ? "not identifiable (its mass or first moment moves no measured row)"
                               : "not separable from the declared model";
            out.payload_first_step.push_back(pf);
          }
          continue;
        }
        const Eigen::Vector4d beta = (Rc.transpose() * Rc).ldlt().solve(Rc.transpose() * ry[F]);
        Eigen::VectorXd d(F);
        Eigen::MatrixXd bfold(4, F);
        double num = 0.0, den = 0.0;
        for (int f = 0; f < F; ++f) {
          const Eigen::MatrixXd Cf = Rtrain[f].middleCols(c0, 4);
          const Eigen::MatrixXd Wf = usolve(Rs[f], Q[f].transpose() * Cf);
          const Eigen::MatrixXd Rcf = Cf - A[f] * Wf;
          const Eigen::Vector4d bf = (Rcf.transpose() * Rcf).ldlt().solve(Rcf.transpose() * ry[f]);
          bfold.col(f) = bf;
          Eigen::VectorXd xP = Eigen::VectorXd::Zero(P);
          const Eigen::VectorXd xsf = xs[f] - Wf * bf;
          for (int k = 0; k < ns; ++k) xP[S[k]] = xsf[k];
          xP.segment<4>(c0) = bf;
          xP[iy] = -1.0;
          d[f] = 0.0;
          for (int r = 0; r < nv; ++r) {
            const double sn = heldout_sse(f, r, xP);
            d[f] += sse_now(f, r) - sn;
            if (ptouch[r][l]) num += sse_now(f, r) - sn, den += sse_now(f, r);
          }
        }
        const double mean = d.mean();
        const double sd = std::sqrt((d.array() - mean).square().sum() / (F - 1));
        pf.mass = beta[0];
        pf.com = beta.tail<3>() / beta[0];
        // Delete-one-fold jackknife of the mass and the CoM (as the single candidates' std_error).
        Eigen::MatrixXd jk(4, F);
        for (int f = 0; f < F; ++f) jk(0, f) = bfold(0, f), jk.col(f).tail<3>() = bfold.col(f).tail<3>() / bfold(0, f);
        const Eigen::VectorXd jmean = jk.rowwise().mean();
        const Eigen::VectorXd jse = ((F - 1.0) / F * (jk.colwise() - jmean).array().square().rowwise().sum()).sqrt();
        pf.mass_se = jse[0];
        pf.com_se = jse.tail<3>();
        pf.explained = den > 0 ? num / den : 0.0;
        pf.t_stat = sd > 0 ? mean / (sd / std::sqrt(static_cast<double>(F))) : (mean > 0 ? INFINITY : 0.0);
        pf.p_value = studentTUpperTail(pf.t_stat, F - 1);
        if (std::getenv("EXOID_DIAGNOSE_DEBUG"))
          std::fprintf(stderr, "step %d payload %s m %.4g c %.3g %.3g %.3g gain %.4g p %.3g expl %.3f sep %.3g\n", step,
                       model.body_names[pf.link].c_str(), pf.mass, pf.com[0], pf.com[1], pf.com[2], mean, pf.p_value,
                       pf.explained, pf.separable);
        // Admissible: a positive mass determined by the data (above 3 jackknife standard errors: a body whose mass the
        // rows cannot pin is model error fitted by 4 free columns) with its CoM within the bound.
        pevals.push_back({l, mean, pf.mass > 3.0 * pf.mass_se && pf.com.norm() <= opt.payload_com_bound, pf});
      }
      const int tested = static_cast<int>(evals.size() + pevals.size());
      const double level = opt.alpha / std::max(tested, 1);  // Bonferroni over the step's candidates
      // The test decides whether a coordinate has an effect at all (some admissible candidate there significant at
      // the Bonferroni level: the false-alarm rate); the held-out gain decides which kind it is, among that
      // coordinate's admissible candidates significant on their own at alpha. (Requiring the kind itself to pass the test let a noisier fold pattern
      // lose to a worse kind: viscous 10 N m s/rad on a hip, gain 1076 at p = 1.7e-4, was named Coulomb, gain 861 at
      // p = 6e-5, with the level at 1.5e-4.) Stribeck's column is a refinement of Coulomb friction: it is named only
      // when it predicts the held-out data clearly better (stribeck_margin) than Coulomb on the same joint.
      const auto usable = [&](const Eval& ev) {
        return ev.admissible && ev.gain > 0 && ev.f.explained >= opt.min_explained;
      };
      std::vector<char> coord_has_effect(static_cast<size_t>(nv), 0);
      for (const Eval& ev : evals)
        if (usable(ev) && ev.f.p_value < level) coord_has_effect[static_cast<size_t>(cands[ev.c].coord)] = 1;
      int best = -1;
      double best_gain = 0.0;
      Finding best_finding;
      // A kind competes on an established coordinate when it is significant on its own at alpha (uncorrected: the
      // multiplicity is already paid by the coordinate's test).
      const auto competes = [&](const Eval& ev) {
        return usable(ev) && ev.f.p_value < opt.alpha && coord_has_effect[static_cast<size_t>(cands[ev.c].coord)];
      };
      for (const Eval& ev : evals)
        if (competes(ev) && ev.gain > best_gain) best_gain = ev.gain, best = ev.c, best_finding = ev.f;
      if (best >= 0 && cands[best].kind == EffectKind::Stribeck)
        for (const Eval& ev : evals)
          if (competes(ev) && cands[ev.c].kind == EffectKind::Coulomb && cands[ev.c].joint == cands[best].joint &&
              ev.gain * (1.0 + opt.stribeck_margin) >= best_gain)
            best = ev.c, best_finding = ev.f;
      // A payload is its own test (Bonferroni level, usable like the others: admissible, a gain, min-explained) and
      // competes with the best effect by held-out gain.
      const auto pusable = [&](const PayloadEval& pe) {
        return pe.admissible && pe.gain > 0 && pe.f.explained >= opt.min_explained;
      };
      int pbest = -1;
      for (size_t k = 0; k < pevals.size(); ++k)
        if (pusable(pevals[k]) && pevals[k].f.p_value < level &&
            pevals[k].gain > std::max(best >= 0 ? best_gain : 0.0, pbest >= 0 ? pevals[static_cast<size_t>(pbest)].gain : 0.0))
          pbest = static_cast<int>(k);
      if (pbest >= 0) best = -1;
      if (step == 0)
        for (size_t k = 0; k < pevals.size(); ++k) {
          PayloadFinding pf = pevals[k].f;
          pf.status = static_cast<int>(k) == pbest       ? "accepted"
                      : !pevals[k].admissible             ? "inadmissible (mass <= 3 standard errors or CoM beyond the bound)"
                      : pf.explained < opt.min_explained  ? "below min-explained"
                      : pf.p_value >= level               ? "not significant"
                                                          : "significant (a larger one was taken first)";
          out.payload_first_step.push_back(pf);
        }
      if (step == 0) {
        for (const Eval& ev : evals) {
          const Candidate& cd = cands[ev.c];
          CandidateScore sc;
          sc.effect = ev.f.effect;
          sc.explained = ev.f.explained;
          sc.p_value = ev.f.p_value;
          sc.separable = ev.separable;
          sc.std_error = ev.jackknife_se;
          Eigen::VectorXd res(out.train_samples), sig(out.train_samples);
          long at = 0;
          for (size_t s = 0; s < train.size(); ++s)
            for (long i = 0; i < caches[s].n; ++i, ++at) {
              res[at] = caches[s].y(i, cd.coord) - caches[s].tau0(i, cd.coord);
              sig[at] = signal(s, i, cd);
            }
          sc.correlation = correlation(res, sig);
          sc.status = ev.c == best                          ? "accepted"
                      : !ev.admissible                      ? "inadmissible sign"
                      : ev.f.explained < opt.min_explained  ? "below min-explained"
                      : !coord_has_effect[static_cast<size_t>(cd.coord)] ? "not significant"
                      : ev.f.p_value >= opt.alpha           ? "not significant"
                      : ev.f.p_value >= level               ? "significant at alpha only (a larger one was taken)"
                                                            : "significant (a larger one was taken first)";
          out.first_step.push_back(sc);
        }
      }
      if (pbest >= 0) {
        const PayloadEval& pe = pevals[static_cast<size_t>(pbest)];
        pdone[static_cast<size_t>(pe.l)] = 1;
        for (int k = 0; k < 4; ++k) S.push_back(pc0 + 4 * pe.l + k);
        pcol.push_back(pc0 + 4 * pe.l);
        out.payloads.push_back(pe.f);
        out.payloads.back().tested = tested;
        out.payloads.back().status = "accepted";
        if (!measurement_cands) continue;
        relinearise = true;  // the gain and delay signals: about the model with the payload (below), then select on
        break;
      }
      if (best < 0) break;
      best_finding.tested = tested;
      S.push_back(m + best);
      fcol.push_back(m + best);
      out.findings.push_back(best_finding);
    }
    if (!relinearise) selecting = false;

    // Final fits (unweighted OLS, the same kind of fit as the declared model's): values, then the
    // standard errors from the weighted problem's covariance.
    Eigen::MatrixXd Ru;
    {
      std::vector<std::pair<int, int>> w;
      for (int f = 0; f < F; ++f)
        for (int r = 0; r < nv; ++r) w.push_back({f, r});
      Ru = merge(w, true);
    }
    const int ns = static_cast<int>(S.size());
    Eigen::MatrixXd Au(P, ns), Aw(P, ns);
    for (int k = 0; k < ns; ++k) Au.col(k) = Ru.col(S[k]), Aw.col(k) = Rtrain[F].col(S[k]);
    const Eigen::VectorXd xprev = xa;
    xa = Au.householderQr().solve(Ru.col(iy));
    if (ns > 0) {  // (none: a held declared model and nothing found)
      Eigen::HouseholderQR<Eigen::MatrixXd> qr(Aw);
      const Eigen::MatrixXd Rw = qr.matrixQR().topRows(ns).triangularView<Eigen::Upper>();
      const Eigen::VectorXd xw = Rw.triangularView<Eigen::Upper>().solve(
          (qr.householderQ() * Eigen::MatrixXd::Identity(P, ns)).transpose() * Rtrain[F].col(iy));
      const double s2 = (Rtrain[F].col(iy) - Aw * xw).squaredNorm() / std::max<double>(total_rows - ns, 1);
      const Eigen::MatrixXd Rinv = Rw.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(ns, ns));
      for (size_t i = 0; i < out.payloads.size(); ++i) {  // final values; the jackknife errors stay the selection's
        const int k = posOf(pcol[i]);
        out.payloads[i].mass = xa[k];
        out.payloads[i].com = Eigen::Vector3d(xa[posOf(pcol[i] + 1)], xa[posOf(pcol[i] + 2)], xa[posOf(pcol[i] + 3)]) / xa[k];
        // Admissibility is decided at selection; a final refit that leaves it says the data do not pin the CoM (a
        // load on a foot flat on its plate: its height moves no torque).
        const bool ok = xa[k] > 0.0 && out.payloads[i].com.norm() <= opt.payload_com_bound;
        out.payloads[i].status = ok ? "accepted" : "accepted; the final refit puts its CoM beyond the bound: not determined";
      }
      for (size_t i = 0; i < out.findings.size(); ++i) {
        const int k = posOf(fcol[i]);
        out.findings[i].effect.value = xa[k];
        out.findings[i].std_error = std::sqrt(s2 * Rinv.row(k).squaredNorm());
      }
    }
    bool linearised = false;
    for (size_t i = 0; i < out.findings.size(); ++i) linearised = linearised || isMeasurementEffect(out.findings[i].effect.kind);
    const bool settled = gn > 0 && xa.size() == xprev.size() &&
                         (xa - xprev).tail(xa.size() - m).cwiseAbs().maxCoeff() <=
                             1e-6 * (1.0 + xa.tail(xa.size() - m).cwiseAbs().maxCoeff());
    if (!relinearise && (!linearised || settled || gn >= 8 + static_cast<int>(pcol.size()))) break;
    relinearise = false;
    // New reference: the augmented model's rigid part (with the payloads found), on every segment.
    const Eigen::VectorXd xr = xa.head(m);
    std::vector<int> ppos;  // positions in xa of the payloads' columns
    for (size_t i = 0; i < pcol.size(); ++i)
      for (int k = 0; k < 4; ++k) ppos.push_back(posOf(pcol[i] + k));
    for (size_t s = 0; s < caches.size(); ++s) {
      Cache& cache = caches[s];
      long i = 0;
      const bool ok = segment(s).stream(
          [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd&, const Eigen::VectorXd&) {
            if (i >= cache.n) return;
            for (int r = 0; r < nv; ++r) {
              double pr = 0.0;
              for (int c = 0; c < m; ++c) pr += K(r, decl[c]) * xr[c];
              for (size_t e = 0; e < ppos.size(); ++e)
                pr += K(r, payloadParam(pcol[e / 4] + static_cast<int>(e % 4))) * xa[ppos[e]];
              cache.tau(i, r) = pr;
            }
            ++i;
          },
          error);
      if (!ok) return false;
      if (i != cache.n) return fail(segment(s).name + ": the data changed between two reads");
      cache.dtau = derivative(cache.t, cache.tau);
    }
    }  // Gauss-Newton
    const Eigen::VectorXd xdecl_after = xa.head(m);

    // Pass D (every segment): residual before and after, per sample.
    std::vector<Candidate> chosen;
    std::vector<int> chosen_pos, payload_pos;  // positions in S (and xa) of the effects' and payloads' columns
    for (size_t i = 0; i < out.findings.size(); ++i) chosen.push_back(cands[fcol[i] - m]), chosen_pos.push_back(posOf(fcol[i]));
    for (size_t i = 0; i < pcol.size(); ++i)
      for (int k = 0; k < 4; ++k) payload_pos.push_back(posOf(pcol[i] + k));
    for (size_t s = 0; s < caches.size(); ++s) {
      const Cache& cache = caches[s];
      ResidualSeries rs;
      rs.segment = segment(s).name;
      rs.validation = s >= train.size();
      rs.t = Eigen::Map<const Eigen::VectorXd>(cache.t.data(), cache.n);
      rs.before = cache.y - cache.tau0;
      rs.after.resize(cache.n, nv);
      rs.v = cache.v;
      rs.a = cache.a;
      rs.tau_model = cache.tau;
      rs.held_base = segment(s).held_base;
      long i = 0;
      const DiagnosisRowSink row = [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd&) {
            if (i >= cache.n) return;
            for (int r = 0; r < nv; ++r) {
              double pr = 0.0;
              for (int c = 0; c < m; ++c) pr += K(r, decl[c]) * xdecl_after[c];
              rs.after(i, r) = y[r] - pr;
            }
            for (size_t e = 0; e < chosen.size(); ++e)
              rs.after(i, chosen[e].coord) -= xa[chosen_pos[e]] * signal(s, i, chosen[e]);
            for (size_t e = 0; e < payload_pos.size(); ++e)
              for (int r = 0; r < nv; ++r)
                rs.after(i, r) -= K(r, payloadParam(pcol[e / 4] + static_cast<int>(e % 4))) * xa[payload_pos[e]];
            ++i;
          };
      // With Segment::stream_state the same rows come with q (for the last stage's dictionary).
      if (segment(s).stream_state) rs.q.resize(cache.n, nj);
      const bool ok = segment(s).stream_state
                          ? segment(s).stream_state(
                                [&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y,
                                    const Eigen::VectorXd& ts, const Eigen::VectorXd& q) {
                                  if (i < cache.n && q.size() == nj) rs.q.row(i) = q.transpose();
                                  row(t, K, y, ts);
                                },
                                error)
                          : segment(s).stream(row, error);
      if (!ok) return false;
      if (i != cache.n) return fail(segment(s).name + ": the data changed between two reads");
      out.series.push_back(std::move(rs));
    }

    // Summaries: held-out = the validation segments when given.
    out.has_validation = !validate.empty();
    auto stack = [&](bool val, bool after, int r) {
      long n = 0;
      for (size_t s = 0; s < out.series.size(); ++s)
        if (out.series[s].validation == val && !unmeasured(s, r)) n += out.series[s].t.size();
      Eigen::VectorXd v(n);
      long at = 0;
      for (size_t s = 0; s < out.series.size(); ++s) {
        const ResidualSeries& rs = out.series[s];
        if (rs.validation == val && !unmeasured(s, r))
          v.segment(at, rs.t.size()) = after ? rs.after.col(r) : rs.before.col(r), at += rs.t.size();
      }
      return v;
    };
    const bool held = out.has_validation;
    double pb = 0, pa = 0, tb = 0, ta = 0;
    long nh = 0, nt = 0;
    for (int r = 0; r < nv; ++r) {
      CoordinateSummary cs;
      cs.name = out.coordinate_names[r];
      cs.joint = model.floating_base ? r - 6 : r;
      const Eigen::VectorXd hb = stack(held, false, r), ha = stack(held, true, r);
      const Eigen::VectorXd trb = stack(false, false, r), tra = stack(false, true, r);
      cs.rms_before = std::sqrt(hb.squaredNorm() / std::max<Eigen::Index>(hb.size(), 1));
      cs.rms_after = std::sqrt(ha.squaredNorm() / std::max<Eigen::Index>(ha.size(), 1));
      cs.train_rms_before = std::sqrt(trb.squaredNorm() / std::max<Eigen::Index>(trb.size(), 1));
      cs.train_rms_after = std::sqrt(tra.squaredNorm() / std::max<Eigen::Index>(tra.size(), 1));
      pb += hb.squaredNorm(), pa += ha.squaredNorm(), nh += hb.size();
      tb += trb.squaredNorm(), ta += tra.squaredNorm(), nt += trb.size();
      if (opt.torque_noise > 0) {
        cs.noise_floor = opt.torque_noise;
      } else if (hb.size() > 2) {
        const Eigen::VectorXd dd = hb.tail(hb.size() - 1) - hb.head(hb.size() - 1);
        cs.noise_floor = std::sqrt(dd.squaredNorm() / dd.size() / 2.0);
      }
      cs.lag1_before = lag1(hb);
      cs.lag1_after = lag1(ha);
      for (const CandidateScore& sc : out.first_step)
        if (model.jointRow(sc.effect.joint) == r && std::fabs(sc.correlation) > std::fabs(cs.best_correlation))
          cs.best_correlation = sc.correlation, cs.best_kind = sc.effect.kind, cs.best_width = sc.effect.width;
      out.coordinates.push_back(cs);
    }
    out.pooled_before = std::sqrt(pb / std::max(nh, 1L));
    out.pooled_after = std::sqrt(pa / std::max(nh, 1L));
    out.train_pooled_before = std::sqrt(tb / std::max(nt, 1L));
    out.train_pooled_after = std::sqrt(ta / std::max(nt, 1L));
    // The last stage: is what remains predictable from the state at all?
    if (!residualPredictability(model, out.series, opt.alpha, opt.min_explained, out.pooled_after, opt.predictability,
                                out.predictability, error))
      return false;
  }

  // Payload candidates without a held declared model: the identified link parameters absorb any payload exactly
  // (its 4 columns are columns of K, inside the declared base parameters' span), so they are not tested.
  for (int b = 0; opt.payload && !opt.hold_declared && b < model.nbodies; ++b) {
    PayloadFinding pf;
    pf.link = b;
    pf.status = "not separable: absorbed by the identified link parameters (hold them: --declared-model)";
    out.payload_first_step.push_back(pf);
  }
  for (PayloadFinding& pf : out.payloads) {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "%s carries a payload of %.3g kg (+- %.2g) at CoM (%.4f, %.4f, %.4f) m (+- %.2g, %.2g, %.2g) in the link "
                  "frame, explains %.0f %% of the residual of the rows it moves (held-out folds; p = %.2g, %d tested)%s",
                  model.body_names[pf.link].c_str(), pf.mass, pf.mass_se, pf.com[0], pf.com[1], pf.com[2], pf.com_se[0],
                  pf.com_se[1], pf.com_se[2], 100.0 * pf.explained, pf.p_value, pf.tested,
                  pf.status == "accepted" ? "" : "; its CoM is not determined by these data (the final refit leaves the bound)");
    pf.sentence = buf;
  }
  // Sentences.
  for (Finding& f : out.findings) {
    char buf[256];
    char width[64] = "";
    if (f.effect.width > 0.0 && isDryFriction(f.effect.kind))
      std::snprintf(width, sizeof width, ", tanh width %g rad/s", f.effect.width);
    std::snprintf(buf, sizeof buf, "%s: %s %s%s, explains %.0f %% of its residual (held-out folds; p = %.2g, %d tested)",
                  model.joint_names[f.effect.joint].c_str(), effectKindWords(f.effect.kind),
                  formatValue(f.effect.kind, f.effect.value, f.std_error).c_str(), width, 100.0 * f.explained,
                  f.p_value, f.tested);
    f.sentence = buf;
  }
  return true;
}

// ---------------------------------------------------------------------------------------------------------
bool writeEffects(const std::string& path, const Model& model, const EffectSet& set, std::string* error) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp);
    if (!f) return error && (*error = "cannot write '" + tmp + "'", true), false;
    char buf[512];
    f << "# Effects the rigid-body model lacks, found by `exoid diagnose` (format: docs/diagnose.md).\n"
         "# Dynamics effects add a column on their joint's row: viscous v, coulomb tanh(v / width),\n"
         "# stribeck tanh(v / width) exp(-(v / stribeck_velocity)^2) (width: the effect's, else coulomb_width),\n"
         "# offset 1, armature dv/dt.\n"
         "# Measurement effects correct the torque: gain g (measured = (1 + g) true), delay d (s, measured(t) =\n"
         "# true(t - d)).\n";
    f << "model: \"" << set.model << "\"\n";
    std::snprintf(buf, sizeof buf, "coulomb_width: %.17g  # rad/s\nstribeck_velocity: %.17g  # rad/s\neffects:\n",
                  set.shape.coulomb_width, set.shape.stribeck_velocity);
    f << buf;
    if (set.effects.empty()) f << "  []\n";
    for (const Effect& e : set.effects) {
      if (e.joint < 0 || e.joint >= model.njoints) return error && (*error = "effect on an unknown joint", true), false;
      if (e.width > 0.0 && isDryFriction(e.kind))
        std::snprintf(buf, sizeof buf, "  - {joint: %s, kind: %s, value: %.17g, width: %.17g}  # %s, rad/s\n",
                      model.joint_names[e.joint].c_str(), effectKindName(e.kind), e.value, e.width, effectUnit(e.kind));
      else
        std::snprintf(buf, sizeof buf, "  - {joint: %s, kind: %s, value: %.17g}  # %s\n", model.joint_names[e.joint].c_str(),
                      effectKindName(e.kind), e.value, effectUnit(e.kind));
      f << buf;
    }
    if (!f.good()) return error && (*error = "write failed on '" + tmp + "'", true), false;
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    if (error) *error = "cannot rename '" + tmp + "' to '" + path + "'";
    return false;
  }
  return true;
}

bool readEffects(const std::string& path, const Model& model, EffectSet& set, std::string* error) {
  auto fail = [&](const std::string& m) {
    if (error) *error = path + ": " + m;
    return false;
  };
  if (std::ifstream probe(path); !probe) return fail("cannot open the file");
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const std::exception& e) {
    return fail(std::string("not readable YAML: ") + e.what());
  }
  set = EffectSet{};
  try {
    if (!root.IsMap()) return fail("expected a mapping with 'effects'");
    for (auto it = root.begin(); it != root.end(); ++it) {
      const std::string key = it->first.as<std::string>();
      if (key != "model" && key != "coulomb_width" && key != "stribeck_velocity" && key != "effects")
        return fail("unknown key '" + key + "'");
    }
    if (root["model"]) set.model = root["model"].as<std::string>();
    if (root["coulomb_width"]) set.shape.coulomb_width = root["coulomb_width"].as<double>();
    if (root["stribeck_velocity"]) set.shape.stribeck_velocity = root["stribeck_velocity"].as<double>();
    if (!(set.shape.coulomb_width > 0) || !std::isfinite(set.shape.coulomb_width) || !(set.shape.stribeck_velocity > 0) ||
        !std::isfinite(set.shape.stribeck_velocity))
      return fail("coulomb_width and stribeck_velocity must be positive and finite");
    const YAML::Node effects = root["effects"];
    if (!effects || !effects.IsSequence()) return fail("'effects' must be a list");
    for (size_t i = 0; i < effects.size(); ++i) {
      const YAML::Node e = effects[i];
      const std::string where = "effects[" + std::to_string(i) + "]";
      if (!e.IsMap() || !e["joint"] || !e["kind"] || !e["value"]) return fail(where + ": needs joint, kind and value");
      Effect ef;
      ef.joint = model.jointIndex(e["joint"].as<std::string>());
      if (ef.joint < 0) return fail(where + ": unknown joint '" + e["joint"].as<std::string>() + "'");
      if (!parseEffectKind(e["kind"].as<std::string>(), ef.kind))
        return fail(where + ": unknown kind '" + e["kind"].as<std::string>() + "'");
      ef.value = e["value"].as<double>();
      if (!std::isfinite(ef.value)) return fail(where + ": value is not finite");
      for (auto kv = e.begin(); kv != e.end(); ++kv) {
        const std::string k = kv->first.as<std::string>();
        if (k != "joint" && k != "kind" && k != "value" && k != "width") return fail(where + ": unknown key '" + k + "'");
      }
      if (e["width"]) {
        ef.width = e["width"].as<double>();
        if (!(ef.width > 0) || !std::isfinite(ef.width)) return fail(where + ": width must be positive and finite");
        if (!isDryFriction(ef.kind))
          return fail(where + ": a width belongs to coulomb and stribeck effects only");
      }
      set.effects.push_back(ef);
    }
  } catch (const std::exception& ex) {
    return fail(std::string("malformed: ") + ex.what());
  }
  return true;
}

// ---------------------------------------------------------------------------------------------------------
int effectColumnCount(const EffectSet& set) {
  int n = 0;
  for (const Effect& e : set.effects) n += isMeasurementEffect(e.kind) ? 0 : 1;
  return n;
}

void effectColumns(const Model& model, const EffectSet& set, const Eigen::Ref<const Eigen::VectorXd>& v,
                   const Eigen::Ref<const Eigen::VectorXd>& a, Eigen::Ref<Eigen::MatrixXd> E) {
  E.setZero();
  int col = 0;
  for (const Effect& e : set.effects) {
    if (isMeasurementEffect(e.kind)) continue;
    E(model.jointRow(e.joint), col++) = effectSignal(e.kind, effectShape(set.shape, e), v[e.joint], a[e.joint], 0.0, 0.0);
  }
}

bool correctMeasurement(const Model& model, const EffectSet& set, Eigen::Ref<Eigen::VectorXd> y,
                        const Eigen::Ref<const Eigen::VectorXd>& tau_sensor) {
  for (const Effect& e : set.effects)
    if (e.kind == EffectKind::Delay) return false;
  for (const Effect& e : set.effects)
    if (e.kind == EffectKind::GainError) {
      const int r = model.jointRow(e.joint);
      y[r] += tau_sensor[r] / (1.0 + e.value) - tau_sensor[r];
    }
  return true;
}

bool correctMeasurement(const Model& model, const EffectSet& set, Eigen::Ref<Eigen::VectorXd> y) {
  for (const Effect& e : set.effects)
    if (e.kind == EffectKind::Delay) return false;
  for (const Effect& e : set.effects)
    if (e.kind == EffectKind::GainError) y[model.jointRow(e.joint)] /= 1.0 + e.value;  // y is the sensor torque
  return true;
}

EffectCorrector::EffectCorrector(const Model& model, const EffectSet& set, RowSink sink)
    : model_(model), set_(set), sink_(std::move(sink)) {
  E_ = Eigen::MatrixXd::Zero(model.nv, effectColumnCount(set));
  v_ = v_prev_ = a_ = Eigen::VectorXd::Zero(model.njoints);
}

void EffectCorrector::add(double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd* tau_sensor) {
  Eigen::VectorXd v(model_.njoints);
  for (int j = 0; j < model_.njoints; ++j) v[j] = K(model_.jointRow(j), model_.frictionParamIndex(j));
  if (pending_) emit(t, v);
  K_ = K, y_ = y, tau_ = tau_sensor ? *tau_sensor : y, v_ = v, t_ = t;
  pending_ = true;
}

void EffectCorrector::finish() {
  if (pending_) emit(t_, v_);
  pending_ = false;
}

void EffectCorrector::emit(double t_next, const Eigen::VectorXd& v_next) {
  // Central difference over the neighbours (one-sided at the ends), as the diagnosis's derivative().
  const double t_lo = has_prev_ ? t_prev_ : t_;
  const Eigen::VectorXd& v_lo = has_prev_ ? v_prev_ : v_;
  a_ = t_next > t_lo ? Eigen::VectorXd((v_next - v_lo) / (t_next - t_lo)) : Eigen::VectorXd::Zero(model_.njoints);
  effectColumns(model_, set_, v_, a_, E_);
  int col = 0;
  for (const Effect& e : set_.effects)
    if (!isMeasurementEffect(e.kind)) y_ -= e.value * E_.col(col++);
  correctMeasurement(model_, set_, y_, tau_);
  sink_(t_, K_, y_);
  t_prev_ = t_, v_prev_ = v_, has_prev_ = true;
}

}  // namespace exoid::estimator
