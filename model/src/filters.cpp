#include "exoid/signal/filters.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <vector>

namespace exoid {

Biquad Biquad::butterworthLowPass(double fc, double fs) { return butterworthSection(fc, fs, 2, 0); }

Biquad Biquad::butterworthSection(double fc, double fs, int order, int section) {
  const double k = std::tan(M_PI * fc / fs);  // pre-warped analogue cutoff
  // Analogue section s^2 + s / Q + 1 (order 2: 1 / Q = sqrt 2), bilinear transform.
  const double inv_q = order == 2 ? M_SQRT2 : 2.0 * std::cos((2 * section + 1) * M_PI / (2.0 * order));
  const double norm = 1.0 / (1.0 + inv_q * k + k * k);
  Biquad c;
  c.b0 = k * k * norm;
  c.b1 = 2.0 * c.b0;
  c.b2 = c.b0;
  c.a1 = 2.0 * (k * k - 1.0) * norm;
  c.a2 = (1.0 - inv_q * k + k * k) * norm;
  return c;
}

void LowPassFilter::configure(int channels, double cutoff_hz, double sample_hz, int order) {
  sections_ = std::clamp(order / 2, 1, Biquad::kMaxOrder / 2);
  x1_ = x2_ = y1_ = y2_ = Eigen::MatrixXd::Zero(channels, sections_);
  initialized_ = false;
  pass_through_ = !(cutoff_hz > 0.0) || !(cutoff_hz < 0.5 * sample_hz);
  for (int s = 0; s < sections_; ++s)
    c_[s] = pass_through_ ? Biquad() : Biquad::butterworthSection(cutoff_hz, sample_hz, 2 * sections_, s);
}

void LowPassFilter::reset(const Eigen::Ref<const Eigen::VectorXd>& value) {
  // Unit DC gain per section: every section's input and output rest at the value.
  for (int s = 0; s < sections_; ++s) x1_.col(s) = x2_.col(s) = y1_.col(s) = y2_.col(s) = value;
  initialized_ = true;
}

void LowPassFilter::filter(const Eigen::Ref<const Eigen::VectorXd>& in, Eigen::Ref<Eigen::VectorXd> out) {
  if (pass_through_) {
    out = in;
    return;
  }
  if (!initialized_) reset(in);
  for (Eigen::Index i = 0; i < in.size(); ++i) {
    double x = in[i];
    for (int s = 0; s < sections_; ++s) {
      const Biquad& c = c_[s];
      const double y = c.b0 * x + c.b1 * x1_(i, s) + c.b2 * x2_(i, s) - c.a1 * y1_(i, s) - c.a2 * y2_(i, s);
      x2_(i, s) = x1_(i, s);
      x1_(i, s) = x;
      y2_(i, s) = y1_(i, s);
      y1_(i, s) = y;
      x = y;  // the next section's input
    }
    out[i] = x;
  }
}

namespace {
// One biquad step of the channels [from, to) of a row, in place (restrict: the state rows and the signal row never
// overlap, so the loop vectorizes).
void biquadStep(const Biquad& c, double* __restrict v, double* __restrict x1, double* __restrict x2,
                double* __restrict y1, double* __restrict y2, Eigen::Index from, Eigen::Index to) {
  for (Eigen::Index k = from; k < to; ++k) {
    const double in = v[k];
    const double y = c.b0 * in + c.b1 * x1[k] + c.b2 * x2[k] - c.a1 * y1[k] - c.a2 * y2[k];
    x2[k] = x1[k], x1[k] = in, y2[k] = y1[k], y1[k] = y;
    v[k] = y;
  }
}
}  // namespace

void filtfiltInPlace(const Biquad& c, SampleMajorMatrix& x, SampleMajorMatrix& scratch) {
  const Eigen::Index n = x.rows(), w = x.cols();
  if (n == 0 || w == 0) return;
  const Eigen::Index pad = std::min<Eigen::Index>(6, n > 1 ? n - 1 : 0);
  // Channels that are zero throughout stay zero and are skipped (a regressor's structural zeros): the runs of the
  // others, [begin, end) pairs.
  std::vector<Eigen::Index> runs;
  {
    std::vector<char> nonzero(static_cast<size_t>(w), 0);
    for (Eigen::Index i = 0; i < n; ++i) {
      const double* r = x.row(i).data();
      for (Eigen::Index k = 0; k < w; ++k) nonzero[static_cast<size_t>(k)] |= r[k] != 0.0;
    }
    for (Eigen::Index k = 0; k < w;) {
      if (!nonzero[static_cast<size_t>(k)]) {
        ++k;
        continue;
      }
      const Eigen::Index begin = k;
      while (k < w && nonzero[static_cast<size_t>(k)]) ++k;
      runs.push_back(begin), runs.push_back(k);
    }
  }
  // Rows of scratch: the state x1, x2, y1, y2, then the forward pass's values over the reflected head (pad rows) and
  // tail (pad rows). The middle n samples' forward values overwrite x itself.
  scratch.resize(4 + 2 * pad, w);
  double* x1 = scratch.row(0).data();
  double* x2 = scratch.row(1).data();
  double* y1 = scratch.row(2).data();
  double* y2 = scratch.row(3).data();
  const auto head = [&](Eigen::Index i) { return scratch.row(4 + i).data(); };        // extended sample i < pad
  const auto tail = [&](Eigen::Index i) { return scratch.row(4 + pad + i).data(); };  // extended sample n + pad + i
  const double* first = x.row(0).data();
  const double* last = x.row(n - 1).data();
  // The reflected ends, as filtfilt builds them (written before the signal is overwritten).
  for (Eigen::Index i = 0; i < pad; ++i) {
    const double* a = x.row(pad - i).data();
    const double* b = x.row(n - 2 - i).data();
    double* h = head(i);
    double* t = tail(i);
    for (Eigen::Index k = 0; k < w; ++k) h[k] = 2.0 * first[k] - a[k], t[k] = 2.0 * last[k] - b[k];
  }
  // One pass of the biquad over the extended rows e(0..n + 2 pad), in place; dir +1 forward, -1 backward.
  const auto row = [&](Eigen::Index e) { return e < pad ? head(e) : e < n + pad ? x.row(e - pad).data() : tail(e - n - pad); };
  const auto pass = [&](Eigen::Index e0, Eigen::Index e1, Eigen::Index dir) {
    const double* s0 = row(e0);
    for (Eigen::Index k = 0; k < w; ++k) x1[k] = x2[k] = y1[k] = y2[k] = s0[k];  // steady state at the first value
    for (Eigen::Index e = e0;; e += dir) {
      double* v = row(e);
      for (size_t r = 0; r < runs.size(); r += 2) biquadStep(c, v, x1, x2, y1, y2, runs[r], runs[r + 1]);
      if (e == e1) break;
    }
  };
  const Eigen::Index end = n + 2 * pad - 1;
  pass(0, end, 1);
  pass(end, 0, -1);
}

Eigen::MatrixXd filtfilt(const Biquad& c, const Eigen::MatrixXd& signal) {
  SampleMajorMatrix x = signal, scratch;
  filtfiltInPlace(c, x, scratch);
  return x;
}

Eigen::MatrixXd differentiate(const Eigen::MatrixXd& s, double dt) {
  const Eigen::Index n = s.rows();
  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(n, s.cols());
  if (n < 2) return d;
  d.row(0) = (s.row(1) - s.row(0)) / dt;
  d.row(n - 1) = (s.row(n - 1) - s.row(n - 2)) / dt;
  if (n > 2) d.middleRows(1, n - 2) = (s.bottomRows(n - 2) - s.topRows(n - 2)) / (2.0 * dt);
  return d;
}

Eigen::Matrix<double, 3, Eigen::Dynamic> savitzkyGolayWeights(int L, int width) {
  if (width < L) width = L;
  const int n = 2 * L + 1;
  Eigen::MatrixXd A(n, 3);
  for (int i = 0; i < n; ++i) A.row(i) << 1.0, double(i - L), double(i - L) * double(i - L);
  Eigen::Matrix<double, 3, Eigen::Dynamic> w = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, 2 * width + 1);
  w.middleCols(width - L, n) = (A.transpose() * A).ldlt().solve(A.transpose());
  return w;
}

void savitzkyGolay(const Eigen::MatrixXd& s, double dt, int L, Eigen::MatrixXd* value, Eigen::MatrixXd* first,
                   Eigen::MatrixXd* second) {
  const Eigen::Index n = s.rows();
  L = std::min<int>(L, static_cast<int>((n - 1) / 2));
  if (L < 1) {  // one or two samples: no curvature to fit
    if (value) *value = s;
    if (first) *first = differentiate(s, dt);
    if (second) second->setZero(n, s.cols());
    return;
  }
  Eigen::MatrixXd v(n, s.cols()), d1(n, s.cols()), d2(n, s.cols());
  const Eigen::Matrix<double, 3, Eigen::Dynamic> w = savitzkyGolayWeights(L);
  const int width = 2 * L + 1;
  auto put = [&](Eigen::Index row, const Eigen::RowVectorXd& c0, const Eigen::RowVectorXd& c1,
                 const Eigen::RowVectorXd& c2, double t) {
    v.row(row) = c0 + t * c1 + t * t * c2;
    d1.row(row) = (c1 + 2.0 * t * c2) / dt;
    d2.row(row) = 2.0 * c2 / (dt * dt);
  };
  for (Eigen::Index i = L; i + L < n; ++i) {
    const auto block = s.middleRows(i - L, width);
    put(i, w.row(0) * block, w.row(1) * block, w.row(2) * block, 0.0);
  }
  // The ends: the first and last full window's quadratic evaluated at the sample's own offset.
  const auto head = s.topRows(width), tail = s.bottomRows(width);
  const Eigen::RowVectorXd h0 = w.row(0) * head, h1 = w.row(1) * head, h2 = w.row(2) * head;
  const Eigen::RowVectorXd t0 = w.row(0) * tail, t1 = w.row(1) * tail, t2 = w.row(2) * tail;
  for (int k = 0; k < L; ++k) {
    put(k, h0, h1, h2, double(k - L));
    put(n - 1 - k, t0, t1, t2, double(L - k));
  }
  if (value) *value = std::move(v);
  if (first) *first = std::move(d1);
  if (second) *second = std::move(d2);
}

}  // namespace exoid
