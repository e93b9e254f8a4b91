// keptInMemory (diagnose.hpp): a segment's rows read once, replayed on every later pass.
#include <algorithm>
#include <cstring>

#include "exoid/estimator/diagnose.hpp"

namespace exoid::estimator {

namespace {

struct KeptSegment {
  Segment source;
  std::shared_ptr<RowMemory> memory;
  bool complete = false;  // every sample of one successful pass is in `blocks`
  bool given_up = false;  // over the budget, or rows of changing sizes: read from the source every time
  Eigen::Index nv = 0, p = 0, nq = -1;  // nq < 0: no sample kept yet
  size_t bytes = 0;                     // what `blocks` hold against the memory's budget
  static constexpr size_t kBlockSamples = 1024;
  std::vector<std::vector<double>> blocks;  // kBlockSamples samples each (the last one partly): t, K (column-major),
                                            // y, tau_sensor, q
  // Replay buffers (the sinks take Eigen objects).
  Eigen::MatrixXd K;
  Eigen::VectorXd y, tau, q;

  size_t stride() const { return static_cast<size_t>(1 + nv * p + 2 * nv + std::max<Eigen::Index>(nq, 0)); }

  void release() {
    memory->used_bytes -= bytes;
    bytes = 0;
    std::vector<std::vector<double>>().swap(blocks);
  }

  // Keeps one sample; false when it does not fit in the budget or its sizes differ from the first's.
  bool keep(double t, const Eigen::MatrixXd& Ks, const Eigen::VectorXd& ys, const Eigen::VectorXd& taus,
            const Eigen::VectorXd* qs) {
    const Eigen::Index nqs = qs ? qs->size() : 0;
    if (nq < 0) nv = Ks.rows(), p = Ks.cols(), nq = nqs;
    if (Ks.rows() != nv || Ks.cols() != p || ys.size() != nv || taus.size() != nv || nqs != nq) return false;
    if (blocks.empty() || blocks.back().size() == kBlockSamples * stride()) {
      const size_t more = kBlockSamples * stride() * sizeof(double);
      if (memory->used_bytes + more > memory->budget_bytes) return false;
      blocks.emplace_back().reserve(kBlockSamples * stride());
      memory->used_bytes += more;
      bytes += more;
    }
    std::vector<double>& b = blocks.back();
    const size_t at = b.size();
    b.resize(at + stride());
    double* d = b.data() + at;
    *d++ = t;
    std::memcpy(d, Ks.data(), sizeof(double) * static_cast<size_t>(nv * p)), d += nv * p;
    std::memcpy(d, ys.data(), sizeof(double) * static_cast<size_t>(nv)), d += nv;
    std::memcpy(d, taus.data(), sizeof(double) * static_cast<size_t>(nv)), d += nv;
    if (nq > 0) std::memcpy(d, qs->data(), sizeof(double) * static_cast<size_t>(nq));
    return true;
  }

  // The first pass: from the source, keeping every sample while it fits.
  bool read(const DiagnosisStateSink& sink, std::string* error) {
    bool keeping = !given_up;
    const auto take = [&](double t, const Eigen::MatrixXd& Ks, const Eigen::VectorXd& ys, const Eigen::VectorXd& taus,
                          const Eigen::VectorXd* qs) {
      if (keeping && !keep(t, Ks, ys, taus, qs)) keeping = false, given_up = true, release();
      sink(t, Ks, ys, taus, qs ? *qs : q);
    };
    nq = -1;
    const bool ok = source.stream_state
                        ? source.stream_state(
                              [&](double t, const Eigen::MatrixXd& Ks, const Eigen::VectorXd& ys,
                                  const Eigen::VectorXd& taus, const Eigen::VectorXd& qs) { take(t, Ks, ys, taus, &qs); },
                              error)
                        : source.stream(
                              [&](double t, const Eigen::MatrixXd& Ks, const Eigen::VectorXd& ys,
                                  const Eigen::VectorXd& taus) { take(t, Ks, ys, taus, nullptr); },
                              error);
    if (!ok || !keeping) {
      release();  // a failed pass keeps nothing: the next one reads the source again
      return ok;
    }
    complete = true;
    return true;
  }

  void replay(const DiagnosisStateSink& sink) {
    K.resize(nv, p), y.resize(nv), tau.resize(nv), q.resize(std::max<Eigen::Index>(nq, 0));
    for (const std::vector<double>& b : blocks)
      for (const double* d = b.data(); d < b.data() + b.size();) {
        const double t = *d++;
        std::memcpy(K.data(), d, sizeof(double) * static_cast<size_t>(nv * p)), d += nv * p;
        std::memcpy(y.data(), d, sizeof(double) * static_cast<size_t>(nv)), d += nv;
        std::memcpy(tau.data(), d, sizeof(double) * static_cast<size_t>(nv)), d += nv;
        if (nq > 0) std::memcpy(q.data(), d, sizeof(double) * static_cast<size_t>(nq)), d += nq;
        sink(t, K, y, tau, q);
      }
  }

  bool pass(const DiagnosisStateSink& sink, std::string* error) {
    if (complete) return replay(sink), true;
    return read(sink, error);
  }

  ~KeptSegment() { release(); }
};

}  // namespace

Segment keptInMemory(Segment source, const std::shared_ptr<RowMemory>& memory) {
  if (!memory || memory->budget_bytes == 0) return source;
  auto kept = std::make_shared<KeptSegment>();
  kept->source = std::move(source);
  kept->memory = memory;
  Segment s;
  s.name = kept->source.name;
  s.held_base = kept->source.held_base;
  s.stream = [kept](const DiagnosisRowSink& sink, std::string* error) {
    return kept->pass([&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd& tau,
                          const Eigen::VectorXd&) { sink(t, K, y, tau); },
                      error);
  };
  if (kept->source.stream_state) s.stream_state = [kept](const DiagnosisStateSink& sink, std::string* error) {
    return kept->pass(sink, error);
  };
  return s;
}

}  // namespace exoid::estimator
