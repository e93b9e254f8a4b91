#pragma once
// The KUKA LWR4+ model of data/kuka_lwr4 (fixed base, 7 joints), loaded once: the synthetic-data tests' arm.
#include <gtest/gtest.h>

#include <string>

#include "exoid/model/urdf.hpp"

namespace exoid::estimator::test {

inline const Model& kuka() {
  static Model model = [] {
    Model m;
    std::string err;
    EXPECT_TRUE(buildModelFromUrdfFile(std::string(EXOID_DATA_DIR) + "/kuka_lwr4/kuka_lwr4.urdf", false, m, &err)) << err;
    return m;
  }();
  return model;
}

}  // namespace exoid::estimator::test
