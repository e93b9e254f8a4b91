#pragma once
// The cross-fitting and the held-out block test shared by the diagnosis' residual stages (residual_predictability.cpp,
// unmeasured_body.cpp): the training rows a held-out fold may be predicted from, and per held-out block b the
// residual's sum of squares ssr_b, a reference model's error sse_ref_b (the residual itself, i.e. predicting zero, or a
// null model) and the tested model's error sse_b.
#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <utility>
#include <vector>

#include "exoid/estimator/diagnose.hpp"

namespace exoid::estimator {

/// The rows of `train_rows` outside the folds `held` and more than `guard` seconds away from them within their segment
/// (the residual is correlated over seconds: a neighbouring sample would leak it). fold [N]: each row's fold (-1: not a
/// training row); seg [N], tt [N]: each row's segment and time (any container indexed by row).
template <class Times>
std::vector<long> trainingRowsOutside(const std::vector<long>& train_rows, const std::vector<int>& fold,
                                      const std::vector<int>& seg, const Times& tt, const std::vector<int>& held,
                                      double guard) {
  auto is_held = [&](long k) { return std::find(held.begin(), held.end(), fold[k]) != held.end(); };
  std::map<int, std::pair<double, double>> span;  // segment -> time range of the held rows
  for (long k : train_rows)
    if (is_held(k)) {
      auto it = span.find(seg[k]);
      if (it == span.end()) span[seg[k]] = {tt[k], tt[k]};
      else it->second.first = std::min(it->second.first, tt[k]), it->second.second = std::max(it->second.second, tt[k]);
    }
  std::vector<long> rows;
  for (long k : train_rows) {
    if (is_held(k)) continue;
    auto it = span.find(seg[k]);
    if (it != span.end() && tt[k] >= it->second.first - guard && tt[k] <= it->second.second + guard) continue;
    rows.push_back(k);
  }
  return rows;
}

struct BlockTest {
  double share = 0.0, se = 0.0, p = 1.0;
};

/// share = (sum sse_ref - sum sse) / sum ssr: the part of the residual the model predicts beyond the reference; its
/// delete-one-block jackknife standard error; p of the one-sided t-test of the mean block gain sse_ref_b - sse_b > 0
/// (blocks - 1 dof; no test with fewer than 3 blocks).
inline BlockTest heldOutBlockTest(const std::vector<double>& ssr, const std::vector<double>& sse_ref,
                                  const std::vector<double>& sse) {
  BlockTest bt;
  const int B = static_cast<int>(ssr.size());
  const double R = std::accumulate(ssr.begin(), ssr.end(), 0.0);
  const double F = std::accumulate(sse_ref.begin(), sse_ref.end(), 0.0), E = std::accumulate(sse.begin(), sse.end(), 0.0);
  if (B == 0 || !(R > 0.0)) return bt;
  bt.share = (F - E) / R;
  if (B < 3) return bt;
  std::vector<double> s(B);
  double ms = 0.0;
  for (int b = 0; b < B; ++b) {
    const double r = R - ssr[b];
    s[b] = r > 0.0 ? ((F - sse_ref[b]) - (E - sse[b])) / r : 0.0;
    ms += s[b] / B;
  }
  double v = 0.0;
  for (double x : s) v += (x - ms) * (x - ms);
  bt.se = std::sqrt((B - 1.0) / B * v);
  double mg = 0.0;
  for (int b = 0; b < B; ++b) mg += (sse_ref[b] - sse[b]) / B;
  double vg = 0.0;
  for (int b = 0; b < B; ++b) vg += (sse_ref[b] - sse[b] - mg) * (sse_ref[b] - sse[b] - mg);
  vg /= (B - 1.0);
  if (vg > 0.0) bt.p = studentTUpperTail(mg / std::sqrt(vg / B), B - 1.0);
  else bt.p = mg > 0.0 ? 0.0 : 1.0;
  return bt;
}

}  // namespace exoid::estimator
