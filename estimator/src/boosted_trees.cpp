// Gradient-boosted trees through XGBoost's C API (boosted_trees.hpp).
#include "exoid/estimator/boosted_trees.hpp"

#include <xgboost/c_api.h>

#include <cstdlib>
#include <limits>
#include <string>

namespace exoid::estimator {

namespace {
// Frees the handles on every path out of fitBoostedTrees.
struct Handles {
  DMatrixHandle train = nullptr, test = nullptr;
  BoosterHandle booster = nullptr;
  ~Handles() {
    if (booster) XGBoosterFree(booster);
    if (train) XGDMatrixFree(train);
    if (test) XGDMatrixFree(test);
  }
};

std::vector<float> rowsOf(const Eigen::MatrixXd& X, const std::vector<long>& rows) {
  std::vector<float> m(rows.size() * static_cast<size_t>(X.cols()));
  for (size_t i = 0; i < rows.size(); ++i)
    for (Eigen::Index c = 0; c < X.cols(); ++c) m[i * X.cols() + c] = static_cast<float>(X(rows[i], c));
  return m;
}
}  // namespace

bool fitBoostedTrees(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, const std::vector<long>& train,
                     const std::vector<long>& predict, const BoostedTreesOptions& o, Eigen::VectorXd& prediction,
                     Eigen::VectorXd* gain, std::string* error) {
  auto failed = [&](const char* what) {
    if (error) *error = std::string("XGBoost: ") + what + ": " + XGBGetLastError();
    return false;
  };
  if (train.empty()) {
    if (error) *error = "XGBoost: no training rows";
    return false;
  }
  Handles h;
  const std::vector<float> xt = rowsOf(X, train);
  std::vector<float> yt(train.size());
  for (size_t i = 0; i < train.size(); ++i) yt[i] = static_cast<float>(y[train[i]]);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  if (XGDMatrixCreateFromMat(xt.data(), train.size(), X.cols(), nan, &h.train)) return failed("training matrix");
  if (XGDMatrixSetFloatInfo(h.train, "label", yt.data(), yt.size())) return failed("labels");
  if (XGBoosterCreate(&h.train, 1, &h.booster)) return failed("booster");
  const std::string params[][2] = {{"objective", "reg:squarederror"},
                                   {"tree_method", "hist"},
                                   {"max_depth", std::to_string(o.depth)},
                                   {"max_bin", std::to_string(o.max_bin)},
                                   {"eta", std::to_string(o.eta)},
                                   {"subsample", std::to_string(o.subsample)},
                                   {"min_child_weight", std::to_string(o.min_child_weight)},
                                   {"nthread", std::to_string(o.threads)},
                                   {"seed", std::to_string(o.seed)},
                                   {"verbosity", "0"}};
  for (const auto& p : params)
    if (XGBoosterSetParam(h.booster, p[0].c_str(), p[1].c_str())) return failed(p[0].c_str());
  for (int it = 0; it < o.rounds; ++it)
    if (XGBoosterUpdateOneIter(h.booster, it, h.train)) return failed("boosting");
  prediction.resize(static_cast<Eigen::Index>(predict.size()));
  if (!predict.empty()) {
    const std::vector<float> xp = rowsOf(X, predict);
    if (XGDMatrixCreateFromMat(xp.data(), predict.size(), X.cols(), nan, &h.test)) return failed("prediction matrix");
    bst_ulong len = 0;
    const float* out = nullptr;
    if (XGBoosterPredict(h.booster, h.test, 0, 0, 0, &len, &out)) return failed("prediction");
    if (len != predict.size()) return failed("prediction size");
    for (size_t i = 0; i < predict.size(); ++i) prediction[static_cast<Eigen::Index>(i)] = out[i];
  }
  if (gain) {
    gain->setZero(X.cols());
    bst_ulong nf = 0, dim = 0;
    const char** names = nullptr;
    const bst_ulong* shape = nullptr;
    const float* scores = nullptr;
    if (XGBoosterFeatureScore(h.booster, R"({"importance_type": "total_gain"})", &nf, &names, &dim, &shape, &scores))
      return failed("feature scores");
    for (bst_ulong i = 0; i < nf; ++i) {  // unnamed features are "f<column>"
      if (names[i][0] != 'f') continue;
      const long c = std::strtol(names[i] + 1, nullptr, 10);
      if (c >= 0 && c < X.cols()) (*gain)[c] = scores[i];
    }
  }
  return true;
}

}  // namespace exoid::estimator
