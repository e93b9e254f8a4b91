#include "exoid/estimator/online/recursive_ls.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "exoid/estimator/batch/accumulator.hpp"
#include "exoid/estimator/batch/solvers.hpp"
#include "exoid/model/regressor.hpp"

namespace exoid::estimator {

namespace {
// Below this common scale the stored sums are multiplied back (they grow like 1 / s).
constexpr double kRenormaliseBelow = 1e-100;

// Multiplies the stored sums back into their true values once the common scale becomes tiny.
void renormalise(const RecursiveLsModel& model, RecursiveLsData& data) {
  if (data.scale >= kRenormaliseBelow) return;
  for (int c = 0; c < model.nv; ++c) {
    data.D[c] *= data.scale;
    data.d[c] *= data.scale;
  }
  data.yy *= data.scale;
  data.scale = 1.0;
}
}  // namespace

bool makeRecursiveLs(const Model& model, const BaseParameters& base, const Eigen::VectorXd& prior_phi,
                     const Eigen::MatrixXd& prior_information, const RecursiveLsOptions& options,
                     RecursiveLsModel& out, std::string* error) {
  auto fail = [&](const std::string& what) {
    if (error) *error = what;
    return false;
  };
  const int p = model.nparams(), m = base.rank, nv = model.nv;
  if (base.nparams != p || static_cast<int>(base.independent.size()) != m || base.base_map.rows() != m ||
      base.base_map.cols() != p)
    return fail("recursive LS: base parameters do not belong to this model");
  if (prior_phi.size() != p) return fail("recursive LS: prior has " + std::to_string(prior_phi.size()) +
                                         " entries, the model has " + std::to_string(p) + " parameters");
  if (!prior_phi.allFinite()) return fail("recursive LS: prior has a non-finite entry");
  if (prior_information.rows() != m || prior_information.cols() != m)
    return fail("recursive LS: prior information must be " + std::to_string(m) + " x " + std::to_string(m));
  if (!prior_information.allFinite()) return fail("recursive LS: prior information has a non-finite entry");
  if ((prior_information - prior_information.transpose()).cwiseAbs().maxCoeff() >
      1e-12 * prior_information.cwiseAbs().maxCoeff())
    return fail("recursive LS: prior information is not symmetric");
  Eigen::LLT<Eigen::MatrixXd> check(prior_information);
  if (check.info() != Eigen::Success) return fail("recursive LS: prior information is not positive definite");
  if (!(options.forgetting > 0.0 && options.forgetting <= 1.0))
    return fail("recursive LS: forgetting factor " + std::to_string(options.forgetting) + " not in (0, 1]");
  if (!options.row_weight.empty() && static_cast<int>(options.row_weight.size()) != nv)
    return fail("recursive LS: " + std::to_string(options.row_weight.size()) + " row weights for " +
                std::to_string(nv) + " coordinates");
  for (double w : options.row_weight)
    if (!(std::isfinite(w) && w > 0.0)) return fail("recursive LS: row weight " + std::to_string(w) + " not > 0");

  out.nv = nv;
  out.p = p;
  out.m = m;
  out.independent = base.independent;
  out.active = activeBaseColumns(model, base);  // the batch accumulator's pattern
  out.x0 = base.base_map * prior_phi;
  out.prior_information = 0.5 * (prior_information + prior_information.transpose());
  out.prior_rhs = out.prior_information * out.x0;
  out.row_weight = Eigen::VectorXd::Ones(nv);
  for (int c = 0; c < static_cast<int>(options.row_weight.size()); ++c) out.row_weight[c] = options.row_weight[c];
  out.forgetting = options.forgetting;
  return true;
}

bool addExtraColumns(RecursiveLsModel& model, const std::vector<int>& rows, const Eigen::VectorXd& prior_sigma,
                     std::string* error) {
  auto fail = [&](const std::string& what) {
    if (error) *error = "recursive LS: " + what;
    return false;
  };
  const int ne = static_cast<int>(rows.size());
  if (prior_sigma.size() != ne)
    return fail(std::to_string(prior_sigma.size()) + " prior sigmas for " + std::to_string(ne) + " extra columns");
  for (int e = 0; e < ne; ++e) {
    if (rows[e] < 0 || rows[e] >= model.nv)
      return fail("extra column " + std::to_string(e) + " on row " + std::to_string(rows[e]) + " of " + std::to_string(model.nv));
    if (!(std::isfinite(prior_sigma[e]) && prior_sigma[e] > 0.0))
      return fail("extra column " + std::to_string(e) + ": prior sigma " + std::to_string(prior_sigma[e]) + " not > 0");
  }
  const int m = model.m, p = model.p;
  for (int e = 0; e < ne; ++e) {
    model.independent.push_back(p + e);  // column p + e of [K | E]
    model.active[rows[e]].push_back(m + e);  // after every base column: the active set stays sorted
  }
  Eigen::MatrixXd info = Eigen::MatrixXd::Zero(m + ne, m + ne);
  info.topLeftCorner(m, m) = model.prior_information;
  for (int e = 0; e < ne; ++e) info(m + e, m + e) = 1.0 / (prior_sigma[e] * prior_sigma[e]);
  model.prior_information = info;
  model.x0.conservativeResize(m + ne);
  model.x0.tail(ne).setZero();
  model.prior_rhs = model.prior_information * model.x0;
  model.m = m + ne;
  model.p = p + ne;
  return true;
}

Eigen::MatrixXd diagonalPriorInformation(const Model& model, const BaseParameters& base,
                                         const Eigen::VectorXd& prior_phi, double relative) {
  const Eigen::VectorXd sigma_std = relative * columnScale(model, prior_phi);
  const Eigen::VectorXd var_base = base.base_map.cwiseAbs2() * sigma_std.cwiseAbs2();
  return var_base.cwiseInverse().asDiagonal();
}

RecursiveLsData::RecursiveLsData(const RecursiveLsModel& model) {
  int kmax = 0;
  D.resize(model.nv);
  d.resize(model.nv);
  for (int c = 0; c < model.nv; ++c) {
    const int k = static_cast<int>(model.active[c].size());
    D[c] = Eigen::MatrixXd::Zero(k, k);
    d[c] = Eigen::VectorXd::Zero(k);
    kmax = std::max(kmax, k);
  }
  yy = Eigen::VectorXd::Zero(model.nv);
  A = model.prior_information;
  b = model.prior_rhs;
  llt = Eigen::LLT<Eigen::MatrixXd, Eigen::Upper>(model.m);
  llt.compute(A);
  x = model.x0;
  covariance = Eigen::MatrixXd::Zero(model.m, model.m);
  sigma = Eigen::VectorXd::Zero(model.m);
  residual_rms = Eigen::VectorXd::Zero(model.nv);
  row = Eigen::VectorXd::Zero(kmax);
  row2 = Eigen::VectorXd::Zero(kmax);
}

SampleStatus updateRecursiveLs(const RecursiveLsModel& model, RecursiveLsData& data, long tick,
                               const Eigen::Ref<const Eigen::MatrixXd>& K, const Eigen::Ref<const Eigen::VectorXd>& y) {
  if (data.has_tick && tick == data.last_tick) {
    ++data.rejected_duplicate;
    return SampleStatus::Duplicate;
  }
  if (data.has_tick && tick < data.last_tick) {
    ++data.rejected_out_of_order;
    return SampleStatus::OutOfOrder;
  }
  // Only the entries the update reads (active columns, y) are checked: nothing is written before this.
  for (int c = 0; c < model.nv; ++c) {
    bool finite = std::isfinite(y[c]);
    for (int j : model.active[c]) finite = finite && std::isfinite(K(c, model.independent[j]));
    if (!finite) {
      ++data.rejected_nonfinite;
      return SampleStatus::NonFinite;
    }
  }
  if (data.has_tick && tick > data.last_tick + 1) data.missing += tick - data.last_tick - 1;
  data.has_tick = true;
  data.last_tick = tick;
  ++data.accepted;

  const double lambda = model.forgetting;
  if (lambda < 1.0) {
    data.scale *= lambda;
    data.effective_samples = lambda * data.effective_samples + 1.0;
    renormalise(model, data);
  } else {
    data.effective_samples += 1.0;
  }
  const double w = 1.0 / data.scale;
  for (int c = 0; c < model.nv; ++c) {
    const std::vector<int>& cols = model.active[c];
    const int k = static_cast<int>(cols.size());
    auto u = data.row.head(k);
    for (int j = 0; j < k; ++j) u[j] = K(c, model.independent[cols[j]]);
    data.D[c].selfadjointView<Eigen::Upper>().rankUpdate(u, w);
    data.d[c].noalias() += (w * y[c]) * u;
    data.yy[c] += w * y[c] * y[c];
  }
  return SampleStatus::Accepted;
}

namespace {
// A += sum_c g_c^2 s D_c (upper triangle), b += sum_c g_c^2 s d_c.
void addInformation(const RecursiveLsModel& model, const RecursiveLsData& data, Eigen::MatrixXd& A,
                    Eigen::VectorXd& b) {
  for (int c = 0; c < model.nv; ++c) {
    const std::vector<int>& cols = model.active[c];
    const int k = static_cast<int>(cols.size());
    const double g2s = model.row_weight[c] * model.row_weight[c] * data.scale;
    for (int j = 0; j < k; ++j) {
      for (int i = 0; i <= j; ++i) A(cols[i], cols[j]) += g2s * data.D[c](i, j);
      b[cols[j]] += g2s * data.d[c][j];
    }
  }
}
}  // namespace

void recursiveLsInformation(const RecursiveLsModel& model, const RecursiveLsData& data, Eigen::MatrixXd& D,
                            Eigen::VectorXd& d) {
  D.setZero();
  d.setZero();
  addInformation(model, data, D, d);
}

void clearRecursiveLsSums(const RecursiveLsModel& model, RecursiveLsData& data) {
  for (int c = 0; c < model.nv; ++c) {
    data.D[c].setZero();
    data.d[c].setZero();
  }
  data.yy.setZero();
  data.scale = 1.0;
  data.effective_samples = 0.0;
}

bool solveRecursiveLs(const RecursiveLsModel& model, RecursiveLsData& data, bool uncertainty,
                      const Eigen::MatrixXd* carried_information, const Eigen::VectorXd* carried_rhs) {
  data.A = model.prior_information;
  data.b = model.prior_rhs;
  if (carried_information) data.A.triangularView<Eigen::Upper>() += *carried_information;
  if (carried_rhs) data.b += *carried_rhs;
  addInformation(model, data, data.A, data.b);
  data.llt.compute(data.A);
  if (data.llt.info() != Eigen::Success) return false;
  data.x = data.b;
  data.llt.solveInPlace(data.x);
  ++data.solves;
  if (uncertainty) {
    // A^-1 a column at a time (triangular vector solves): the blocked matrix solve needs a workspace beyond Eigen's
    // stack limit (128 KiB) once m passes ~128 (100 base parameters, 20 sensor columns, 6 for a wearer's trunk and a
    // sidecar's), and the publication path may not allocate.
    data.covariance.setIdentity();
    for (Eigen::Index j = 0; j < data.covariance.cols(); ++j) data.llt.solveInPlace(data.covariance.col(j));
    data.sigma = data.covariance.diagonal().cwiseSqrt();
  }
  // rss_c(x) = s (x_c^T D_c x_c - 2 d_c^T x_c + yy_c), unweighted.
  for (int c = 0; c < model.nv; ++c) {
    const std::vector<int>& cols = model.active[c];
    const int k = static_cast<int>(cols.size());
    auto xc = data.row.head(k);
    for (int j = 0; j < k; ++j) xc[j] = data.x[cols[j]];
    auto Dx = data.row2.head(k);
    Dx.noalias() = data.D[c].selfadjointView<Eigen::Upper>() * xc;
    const double quad = xc.dot(Dx);
    const double rss = std::max(0.0, data.scale * (quad - 2.0 * data.d[c].dot(xc) + data.yy[c]));
    data.residual_rms[c] = data.effective_samples > 0 ? std::sqrt(rss / data.effective_samples) : 0.0;
  }
  return true;
}

void predictRecursiveLs(const RecursiveLsModel& model, const RecursiveLsData& data,
                        const Eigen::Ref<const Eigen::MatrixXd>& K, Eigen::Ref<Eigen::VectorXd> tau) {
  predictRecursiveLs(model, data.x, K, tau);
}

void predictRecursiveLs(const RecursiveLsModel& model, const Eigen::VectorXd& x,
                        const Eigen::Ref<const Eigen::MatrixXd>& K, Eigen::Ref<Eigen::VectorXd> tau) {
  for (int c = 0; c < model.nv; ++c) {
    double sum = 0.0;
    for (int j : model.active[c]) sum += K(c, model.independent[j]) * x[j];
    tau[c] = sum;
  }
}

namespace {
constexpr char kMagic[8] = {'E', 'X', 'O', 'R', 'L', 'S', '0', '1'};

// The model's structure as the checkpoint stores it: a restored state is only valid for the same one.
std::vector<double> structure(const RecursiveLsModel& model) {
  std::vector<double> v = {double(model.nv), double(model.m), double(model.p), model.forgetting};
  for (const auto& cols : model.active) {
    v.push_back(double(cols.size()));
    for (int j : cols) v.push_back(j);
  }
  for (int j : model.independent) v.push_back(j);
  for (int j = 0; j < model.m; ++j) v.push_back(model.x0[j]);
  for (int c = 0; c < model.nv; ++c) v.push_back(model.row_weight[c]);
  for (int i = 0; i < model.prior_information.size(); ++i) v.push_back(model.prior_information.data()[i]);
  return v;
}
}  // namespace

bool saveRecursiveLs(const RecursiveLsModel& model, const RecursiveLsData& data, const std::string& path,
                     std::string* error, const std::vector<double>& extra) {
  std::vector<double> v = structure(model);
  const double header_size = double(v.size());
  v.insert(v.begin(), header_size);
  for (int c = 0; c < model.nv; ++c) {
    v.insert(v.end(), data.D[c].data(), data.D[c].data() + data.D[c].size());
    v.insert(v.end(), data.d[c].data(), data.d[c].data() + data.d[c].size());
  }
  v.insert(v.end(), data.yy.data(), data.yy.data() + data.yy.size());
  for (double x : {data.scale, data.effective_samples, double(data.last_tick), double(data.has_tick),
                   double(data.accepted), double(data.rejected_nonfinite), double(data.rejected_out_of_order),
                   double(data.rejected_duplicate), double(data.missing)})
    v.push_back(x);
  if (!extra.empty()) {
    v.push_back(double(extra.size()));
    v.insert(v.end(), extra.begin(), extra.end());
  }
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(kMagic, sizeof kMagic);
    const double n = double(v.size());
    out.write(reinterpret_cast<const char*>(&n), sizeof n);
    out.write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * sizeof(double)));
    if (!out) {
      if (error) *error = tmp + ": cannot write the checkpoint";
      return false;
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    if (error) *error = path + ": cannot rename " + tmp + " onto it";
    return false;
  }
  return true;
}

bool loadRecursiveLs(const RecursiveLsModel& model, RecursiveLsData& data, const std::string& path,
                     std::string* error, std::vector<double>* extra) {
  auto fail = [&](const std::string& what) {
    if (error) *error = path + ": " + what;
    return false;
  };
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail("cannot open the checkpoint");
  char magic[sizeof kMagic];
  double n = 0;
  if (!in.read(magic, sizeof magic) || std::string(magic, sizeof magic) != std::string(kMagic, sizeof kMagic))
    return fail("not an estimator checkpoint (bad magic)");
  if (!in.read(reinterpret_cast<char*>(&n), sizeof n) || !(n >= 1 && n < 1e9)) return fail("bad length field");
  std::vector<double> v(static_cast<size_t>(n));
  if (!in.read(reinterpret_cast<char*>(v.data()), std::streamsize(v.size() * sizeof(double))))
    return fail("truncated (" + std::to_string(v.size()) + " values expected)");
  if (in.peek() != std::char_traits<char>::eof()) return fail("trailing bytes after the checkpoint");
  const std::vector<double> s = structure(model);
  if (v[0] != double(s.size()) || v.size() < s.size() + 1 || !std::equal(s.begin(), s.end(), v.begin() + 1)) {
    std::string counts;  // the parameter count names the usual cause: other extra (effect) columns
    if (v.size() >= 4 && (v[2] != s[1] || v[3] != s[2]))
      counts = ": it estimates " + std::to_string(long(v[2])) + " parameters (extra columns included), this one " +
               std::to_string(model.m);
    return fail("written for a different estimator (model structure, prior, weights or forgetting differ)" + counts);
  }
  size_t i = s.size() + 1;
  size_t need = i + model.nv + 9;
  for (int c = 0; c < model.nv; ++c) need += data.D[c].size() + data.d[c].size();
  size_t n_extra = 0;
  if (v.size() > need) n_extra = v[need] >= 1 && v[need] < 1e9 ? size_t(v[need]) : v.size();
  if (v.size() != need && v.size() != need + 1 + n_extra)
    return fail("size " + std::to_string(v.size()) + " does not match the model (" + std::to_string(need) + ")");
  for (size_t k = s.size() + 1; k < v.size(); ++k)
    if (!std::isfinite(v[k])) return fail("non-finite value at position " + std::to_string(k));
  RecursiveLsData restored = data;
  for (int c = 0; c < model.nv; ++c) {
    std::copy(v.begin() + i, v.begin() + i + restored.D[c].size(), restored.D[c].data());
    i += restored.D[c].size();
    std::copy(v.begin() + i, v.begin() + i + restored.d[c].size(), restored.d[c].data());
    i += restored.d[c].size();
  }
  std::copy(v.begin() + i, v.begin() + i + model.nv, restored.yy.data());
  i += model.nv;
  restored.scale = v[i++];
  restored.effective_samples = v[i++];
  restored.last_tick = long(v[i++]);
  restored.has_tick = v[i++] != 0.0;
  restored.accepted = long(v[i++]);
  restored.rejected_nonfinite = long(v[i++]);
  restored.rejected_out_of_order = long(v[i++]);
  restored.rejected_duplicate = long(v[i++]);
  restored.missing = long(v[i++]);
  if (!(restored.scale > 0.0 && restored.scale <= 1.0)) return fail("scale out of (0, 1]");
  data = std::move(restored);
  if (extra) extra->assign(v.begin() + static_cast<std::ptrdiff_t>(v.size() - n_extra), v.end());
  return true;
}

void discountRecursiveLs(const RecursiveLsModel& model, RecursiveLsData& data, double kappa) {
  if (!(kappa > 0.0 && kappa <= 1.0)) return;
  data.scale *= kappa;
  data.effective_samples *= kappa;
  renormalise(model, data);
}

}  // namespace exoid::estimator
