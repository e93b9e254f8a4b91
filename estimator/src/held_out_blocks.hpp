#pragma once
// The held-out block test shared by the diagnosis' residual stages (residual_predictability.cpp, unmeasured_body.cpp):
// per held-out block b, the residual's sum of squares ssr_b, a reference model's error sse_ref_b (the residual itself,
// i.e. predicting zero, or a null model) and the tested model's error sse_b.
#include <cmath>
#include <numeric>
#include <vector>

#include "exoid/estimator/diagnose.hpp"

namespace exoid::estimator {

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
