#pragma once
// A synthetic run for the diagnosis tests (test_diagnose, test_diagnose_stages): states, times and measured y, and the
// Segment that streams its rows, with q (Segment::stream_state) so that the elastic candidates are tested too.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "exoid/estimator/diagnose.hpp"
#include "exoid/model/regressor.hpp"

namespace exoid::estimator::diagnosis_runs {

struct Run {
  std::vector<State> states;
  std::vector<double> t;
  std::vector<Eigen::VectorXd> y;
};

/// The run's rows (fixed base: y is the sensor torque, the fourth argument too); the run must outlive the segment.
inline Segment segmentOf(const Model& model, const Run& run, const std::string& name) {
  Segment sg{name, [&model, &run](const DiagnosisRowSink& sink, std::string*) {
               Data data(model);
               for (size_t i = 0; i < run.states.size(); ++i) {
                 computeJointTorqueRegressor(model, data, run.states[i]);
                 sink(run.t[i], data.K, run.y[i], run.y[i]);
               }
               return true;
             }};
  sg.stream_state = [&model, &run](const DiagnosisStateSink& sink, std::string*) {
    Data data(model);
    for (size_t i = 0; i < run.states.size(); ++i) {
      computeJointTorqueRegressor(model, data, run.states[i]);
      sink(run.t[i], data.K, run.y[i], run.y[i], run.states[i].q);
    }
    return true;
  };
  return sg;
}

}  // namespace exoid::estimator::diagnosis_runs
