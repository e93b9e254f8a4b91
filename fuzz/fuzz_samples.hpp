#pragma once
// Shared by the fuzz targets of the measured-data intake (fuzz_log_samples, fuzz_measured_csv).
#include <cmath>

#include "exoid/estimator/dataset.hpp"

namespace exoid::fuzz {

/// Every value a measured sample hands on is finite: the time, the joints, the base, the contacts.
inline bool allValuesFinite(const estimator::MeasuredSample& s) {
  bool ok = std::isfinite(s.t) && s.q.allFinite() && s.tau.allFinite() && s.v.allFinite() && s.a.allFinite() &&
            s.base_orientation.coeffs().allFinite() && s.base_omega.allFinite() && s.base_acceleration.allFinite() &&
            s.base_position.allFinite() && s.base_domega.allFinite();
  for (int i = 0; i < s.ncontacts; ++i)
    ok = ok && s.contact[i].force.allFinite() && s.contact[i].moment_world_origin.allFinite() &&
         s.plate_position[i].allFinite();
  return ok;
}

}  // namespace exoid::fuzz
