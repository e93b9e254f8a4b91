#include "exoid/tools/identify_input.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <vector>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/sole_placement.hpp"
#include "exoid/estimator/sole_tilt.hpp"


namespace exoid::tools {

void applyBaseSignals(const BaseSignals& b, SourceOptions& so) {
  const bool sensors = so.pipeline == intake::LogPipeline::Sensors;
  estimator::DatasetOptions& d = so.dataset;
  d.orientation_from_legs = sensors && (b.orientation == "plates" || b.orientation == "fused");
  so.fit_sole_tilt = d.orientation_from_legs && b.orientation == "plates";
  d.base_rate_from_legs = sensors && b.rate == "legs";
  d.base_acceleration_from_legs = sensors && b.acceleration == "legs";
  d.orientation_cutoff_hz = b.orientation_cutoff_hz;
  so.sole_on_plate = b.sole_on_plate;
  so.fit_sole_placement = b.fit_sole_placement;
}

std::vector<ProcessingAlternative> processingAlternatives(const SourceOptions& training, bool logs_on_floating_base) {
  std::vector<ProcessingAlternative> out;
  const estimator::DatasetOptions& d = training.dataset;
  if (d.cutoff_hz > 0.0) {
    char what[64];
    std::snprintf(what, sizeof what, "cutoff %g Hz", 0.5 * d.cutoff_hz);
    ProcessingAlternative half{what, training};
    half.source.dataset.cutoff_hz = 0.5 * d.cutoff_hz;
    out.push_back(half);
    // Parallel filtering is not an alternative to the default (filtering the inputs): on the exoskeleton's runs it
    // never changed which directions were kept, and it holds every column of the whole run (docs/identification.md).
    if (d.filter == estimator::FilterMode::Parallel) {
      ProcessingAlternative inputs{"filtering the inputs", training};
      inputs.source.dataset.filter = estimator::FilterMode::Inputs;
      out.push_back(inputs);
    }
  }
  // The legs' rate and acceleration (the default) are biased where the feet tilt on their contacts, which no
  // resampling sees; the IMU is unbiased but noisy, mostly above a few Hz. With the fused orientation the alternative
  // takes the IMU's below the orientation's fusion cutoff, as the orientation does: it moves what the legs' bias
  // moves, plus the IMU's small low-band noise (ten prior draws on one nominal run pair at 15 Hz: 5 of 10 within
  // 10 % of the validation choice without it, 9 of 10 with it). With the soles' tilt fitted to the plates (the
  // default) the tilt is in the model, and what that alternative moves is the IMU's low-band noise: dropped there
  // (140 draws over seven run pairs: 126 within 10 % against 124, worst 1.27 against 1.73; the table's prior at 15 Hz
  // on six pairs: 6 of 6 against 1 of 6, worst 1.04 against 2.77; docs/identification.md, stop 50). The IMU's whole
  // orientation or rate would move weak directions by the IMU's own noise (400 times the encoders'). With the gyro's
  // rate the IMU's orientation stays the alternative (as measured then).
  if (!d.orientation_from_legs || !logs_on_floating_base) return out;
  if ((d.base_rate_from_legs || d.base_acceleration_from_legs) && !training.fit_sole_tilt) {
    ProcessingAlternative imu{"IMU below the fusion cutoff", training};
    imu.source.dataset.imu_below_fusion_cutoff = true;
    out.push_back(imu);
  }
  if (!d.base_rate_from_legs) {
    ProcessingAlternative imu{"IMU orientation", training};
    imu.source.dataset.orientation_from_legs = false;
    out.push_back(imu);
  }
  return out;
}

bool isCsvPath(const std::string& path) {
  return path.size() >= 4 && (path.compare(path.size() - 4, 4, ".csv") == 0 || path.compare(path.size() - 4, 4, ".CSV") == 0);
}

namespace {
// The feet (floating base) and the dataset options with the sole footholds filled in.
bool datasetSetup(const Model& model, const SourceOptions& options, int feet[2], estimator::DatasetOptions& dopt,
                  std::string* error) {
  feet[0] = feet[1] = -1;
  dopt = options.dataset;
  if (model.floating_base) {
    feet[0] = model.bodyIndex("right_foot");
    feet[1] = model.bodyIndex("left_foot");
    if (feet[0] < 0 || feet[1] < 0) {
      if (error) *error = "a floating-base identification needs the model's right_foot and left_foot links";
      return false;
    }
    if (dopt.footholds.empty()) dopt.footholds = estimator::defaultFootholds(model, options.sole_on_plate);
  }
  return true;
}

bool readFile(const std::string& path, const Model& model, const SourceOptions& options, const int feet[2],
              const intake::SampleSink& sink, intake::InputStats& stats, std::string* error) {
  return isCsvPath(path) ? intake::streamMeasuredCsv(path, model, feet, options.skip_bad_rows, sink, stats, error)
                         : intake::streamRunLog(path, model, options.pipeline, feet, options.allow_partial, sink, stats, error);
}

estimator::RowSink accumulatorSink(estimator::LsqAccumulator& acc, long& nonfinite) {
  return [&acc, &nonfinite](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
    if (!acc.add(K, y)) ++nonfinite;
  };
}

// A sample of a run with the pelvis held by a harness (SourceOptions::held_base): the base at rest, no contact.
void heldBase(estimator::MeasuredSample& s) {
  s.base_omega.setZero();
  s.base_domega.setZero();
  s.base_acceleration.setZero();
  s.has_base_domega = true;
  s.has_base_position = true;  // not needed by K; keeps the footholds (feet on the plates) out of it
  s.ncontacts = 0;
}

// SourceOptions::fit_sole_placement: the samples' rows built as declared (dopt) and with both soles moved by h in x and
// in y (y is affine in the base position, so the difference over h is exact), fitted by estimator::SolePlacementFit;
// where fitted, the offset is added to dopt's footholds. Nothing to fit (out.why_not empty) where every sample records
// its base's position.
bool fitSolePlacement(const std::vector<estimator::MeasuredSample>& samples, const Model& model,
                      estimator::DatasetOptions& dopt, const std::string& path, estimator::SolePlacement& out,
                      std::string* error) {
  out = estimator::SolePlacement();
  const auto recorded = [](const estimator::MeasuredSample& s) { return s.has_base_position; };
  if (std::all_of(samples.begin(), samples.end(), recorded))
    return true;
  constexpr double h = 0.01;  // m
  auto build = [&](const Eigen::Vector3d& by, const estimator::RowSink& sink) {
    estimator::DatasetOptions o = dopt;
    for (estimator::DatasetOptions::Foothold& f : o.footholds) f.world += by;
    estimator::DatasetBuilder b(model, o, sink);
    std::string err;
    for (const estimator::MeasuredSample& s : samples)
      if (!b.add(s, &err)) return (error ? *error = path + ": " + err : err), false;
    if (!b.finish(&err)) return (error ? *error = path + ": " + err : err), false;
    return true;
  };
  std::vector<Eigen::VectorXd> yx, yy;
  const auto keepY = [](std::vector<Eigen::VectorXd>& into) {
    return [&into](double, const Eigen::MatrixXd&, const Eigen::VectorXd& y) { into.push_back(y); };
  };
  if (!build(Eigen::Vector3d(h, 0, 0), keepY(yx)) || !build(Eigen::Vector3d(0, h, 0), keepY(yy))) return false;
  estimator::SolePlacementFit fit(model, computeBaseParameters(model));
  Eigen::MatrixXd dY(model.nv, 2);
  size_t k = 0;
  const bool ok = build(Eigen::Vector3d::Zero(), [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
    if (k < yx.size() && k < yy.size()) {
      dY.col(0) = (yx[k] - y) / h;
      dY.col(1) = (yy[k] - y) / h;
      fit.add(K, y, dY);
    }
    ++k;
  });
  if (!ok) return false;
  if (k != yx.size() || k != yy.size()) {
    if (error) *error = path + ": the soles' placement fit: the three builds gave different row counts";
    return false;
  }
  out = fit.finish();
  if (out.fitted)
    for (estimator::DatasetOptions::Foothold& f : dopt.footholds) f.world.head<2>() += out.offset;
  return true;
}

using BuilderRowSink = std::function<void(const estimator::DatasetBuilder& builder, double t, const Eigen::MatrixXd& K,
                                          const Eigen::VectorXd& y)>;

// Streams a file's rows through the dataset builder and, when the source has a sidecar, its corrections.
bool streamRows(const std::string& path, const Model& model, const SourceOptions& options, const BuilderRowSink& rows,
                intake::InputStats& stats, std::string* error) {
  int feet[2];
  estimator::DatasetOptions dopt;
  if (!datasetSetup(model, options, feet, dopt, error)) return false;
  if (options.base_rows_only && !model.floating_base) {
    if (error) *error = path + ": base rows only needs a floating-base model";
    return false;
  }
  if (options.held_base && !model.floating_base) {
    if (error) *error = path + ": a held base needs a floating-base model";
    return false;
  }
  if (options.held_base) {  // the feet swing: they say nothing of the base
    dopt.orientation_from_legs = false;
    dopt.base_rate_from_legs = false;
    dopt.base_acceleration_from_legs = false;
  }
  // The fits over the whole file first, from one more read of it (the samples kept in memory for the placement's
  // three builds; the tilt alone streams them); the file is read again below, counted there.
  const bool tilt = options.fit_sole_tilt && dopt.orientation_from_legs && model.floating_base && !options.held_base;
  const bool place = options.fit_sole_placement && model.floating_base && !options.held_base;
  estimator::SolePlacement placement;
  if (tilt || place) {
    estimator::SoleTiltFit tilt_fit(model, dopt.footholds);
    std::vector<estimator::MeasuredSample> samples;
    intake::InputStats first;
    const intake::SampleSink pass = [&](const estimator::MeasuredSample& s, std::string*) {
      if (tilt) tilt_fit.add(s);
      if (place) samples.push_back(s);
      return true;
    };
    if (!readFile(path, model, options, feet, pass, first, error)) return stats = first, false;
    if (tilt) dopt.sole_tilt = tilt_fit.finish();
    if (place && !fitSolePlacement(samples, model, dopt, path, placement, error)) return false;
  }
  if (options.held_function && (options.held_function->c.size() != model.nparams() || options.held_function->j < 0 ||
                                 options.held_function->j >= model.nparams())) {
    if (error) *error = path + ": the held function does not match the model's size";
    return false;
  }
  if (options.held_phi && options.held_phi->size() != model.nparams()) {
    if (error) *error = path + ": the held parameters do not match the model's size";
    return false;
  }
  const estimator::DatasetBuilder* self = nullptr;
  Eigen::MatrixXd Kh;  // held base: the rows with the unmeasured ones (heldBaseRowMeasured) zeroed
  Eigen::VectorXd yh, kj;
  const estimator::RowSink direct = [&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
    if (!options.held_base && !options.held_phi && !options.base_rows_only && !options.held_function)
      return rows(*self, t, K, y);
    Kh = K, yh = y;
    if (const estimator::HeldFunction* h = options.held_function) {
      kj = Kh.col(h->j);  // a copy: the rank-1 update below rewrites column j (to zero: c_j = 1)
      yh.noalias() -= kj * h->value;
      Kh.noalias() -= kj * h->c.transpose();
    }
    for (int r = 0; options.held_base && r < model.nv; ++r)
      if (!estimator::heldBaseRowMeasured(model, r)) Kh.row(r).setZero(), yh[r] = 0.0;
    if (options.base_rows_only) Kh.bottomRows(model.njoints).setZero(), yh.tail(model.njoints).setZero();
    if (options.held_phi) yh.noalias() -= Kh * *options.held_phi;  // what the held parameters leave
    rows(*self, t, Kh, yh);
  };
  std::unique_ptr<estimator::EffectCorrector> corrector;
  if (options.effects) corrector = std::make_unique<estimator::EffectCorrector>(model, *options.effects, direct);
  estimator::DatasetBuilder builder(model, dopt, corrector ? estimator::RowSink([&](double t, const Eigen::MatrixXd& K,
                                                                                     const Eigen::VectorXd& y) {
                                                   corrector->add(t, K, y, &self->sensorTorque(), &self->jointPosition());
                                                 })
                                                           : direct);
  self = &builder;
  estimator::MeasuredSample held;
  const intake::SampleSink sink = [&](const estimator::MeasuredSample& s, std::string* err) {
    if (!options.held_base) return builder.add(s, err);
    held = s;
    heldBase(held);
    return builder.add(held, err);
  };
  if (!readFile(path, model, options, feet, sink, stats, error)) return false;
  stats.sole_tilt = dopt.sole_tilt;  // the reader starts its statistics afresh
  stats.sole_placement = placement;
  std::string err;
  if (!builder.finish(&err)) {
    if (error) *error = path + ": " + err;
    return false;
  }
  if (corrector) corrector->finish();
  return true;
}
}  // namespace

bool streamFileRows(const std::string& path, const Model& model, const SourceOptions& options,
                    const estimator::RowSink& rows, intake::InputStats& stats, std::string* error) {
  return streamRows(
      path, model, options,
      [&](const estimator::DatasetBuilder&, double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) { rows(t, K, y); },
      stats, error);
}

bool streamFileRows(const std::string& path, const Model& model, const SourceOptions& options,
                    const TorqueRowSink& rows, intake::InputStats& stats, std::string* error) {
  if (options.effects) {  // the corrector delays rows by one sample: the builder's torque would be the next one's
    if (error) *error = "streamFileRows: sensor torques and sidecar corrections together are not supported";
    return false;
  }
  return streamRows(
      path, model, options,
      [&](const estimator::DatasetBuilder& b, double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
        rows(t, K, y, b.sensorTorque());
      },
      stats, error);
}

bool streamFileStateRows(const std::string& path, const Model& model, const SourceOptions& options,
                         const StateRowSink& rows, intake::InputStats& stats, std::string* error) {
  if (options.effects) {
    if (error) *error = "streamFileStateRows: sensor torques and sidecar corrections together are not supported";
    return false;
  }
  return streamRows(
      path, model, options,
      [&](const estimator::DatasetBuilder& b, double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
        rows(t, K, y, b.sensorTorque(), b.jointPosition());
      },
      stats, error);
}

bool readSamples(const std::string& path, const Model& model, const SourceOptions& options,
                 std::vector<estimator::MeasuredSample>& out, intake::InputStats& stats, std::string* error) {
  if (options.held_base) {  // the study's path: held-base runs go through streamFileRows
    if (error) *error = "readSamples: held-base runs are not supported here";
    return false;
  }
  int feet[2];
  estimator::DatasetOptions dopt;
  if (!datasetSetup(model, options, feet, dopt, error)) return false;
  out.clear();
  const intake::SampleSink sink = [&](const estimator::MeasuredSample& s, std::string*) { return out.push_back(s), true; };
  return readFile(path, model, options, feet, sink, stats, error);
}

bool accumulateSamples(const std::vector<estimator::MeasuredSample>& samples, const Model& model,
                       const SourceOptions& options, estimator::LsqAccumulator& acc, intake::InputStats& stats,
                       std::string* error) {
  // The study's path; these go through streamFileRows.
  if (options.effects || options.held_base || options.held_phi || options.base_rows_only || options.held_function) {
    if (error) *error = "accumulateSamples: sidecar corrections, held-base runs, held parameters and base rows only "
                        "are not supported here";
    return false;
  }
  int feet[2];
  estimator::DatasetOptions dopt;
  if (!datasetSetup(model, options, feet, dopt, error)) return false;
  if (options.fit_sole_tilt && dopt.orientation_from_legs && model.floating_base) {
    estimator::SoleTiltFit fit(model, dopt.footholds);
    for (const estimator::MeasuredSample& s : samples) fit.add(s);
    dopt.sole_tilt = stats.sole_tilt = fit.finish();
  }
  if (options.fit_sole_placement && model.floating_base &&
      !fitSolePlacement(samples, model, dopt, "samples", stats.sole_placement, error))
    return false;
  long nonfinite = 0;
  estimator::DatasetBuilder builder(model, dopt, accumulatorSink(acc, nonfinite));
  for (const estimator::MeasuredSample& s : samples)
    if (!builder.add(s, error)) return false;
  if (!builder.finish(error)) return false;
  stats.samples = static_cast<long>(samples.size());
  if (nonfinite > 0) {
    stats.skipped += nonfinite;
    stats.why["non-finite regressor row"] += nonfinite;
  }
  return true;
}

bool accumulateFile(const std::string& path, const Model& model, const SourceOptions& options,
                    estimator::LsqAccumulator& acc, intake::InputStats& stats, std::string* error) {
  long nonfinite = 0;
  if (!streamFileRows(path, model, options, accumulatorSink(acc, nonfinite), stats, error)) return false;
  if (nonfinite > 0) {
    stats.skipped += nonfinite;
    stats.why["non-finite regressor row"] += nonfinite;
  }
  return true;
}

}  // namespace exoid::tools
