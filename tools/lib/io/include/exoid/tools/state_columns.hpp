#pragma once
// The states CSV schema of docs/data-formats.md: q_<joint>, v_<joint>, a_<joint> per URDF joint and, for a
// floating base, base_qw..qz (world <- base, Hamilton), base_wx..wz, base_dwx..dwz, base_ax..az (all base
// coordinates; a = classical acceleration of the base origin, gravity excluded) and optionally base_vx..vz
// (base coordinates) and base_px..pz (world), which do not enter K. Other columns (t, tau_*, fp_*, ...) are ignored by readers.
#include <string>
#include <vector>

#include "exoid/model/model.hpp"
#include "exoid/tools/csv.hpp"

namespace exoid::tools {

class StateColumns {
 public:
  /// Column names written for a model, in order (without t).
  static std::vector<std::string> names(const Model& model, bool with_base_position = true);
  /// Finds every required column of the model in a table. Fails naming a missing column, or a q_/v_/a_
  /// column whose joint the model does not have, or an unknown base_ column.
  bool bind(const Model& model, const CsvTable& table, std::string* error);
  /// Fills a state (sized for the model) from one row. Fails if the quaternion is not unit length
  /// within 1e-3 (it is normalised otherwise).
  /// Every value read must be within the gate's kMaxSampleMagnitude (sample_checks.hpp: beyond it the
  /// regressor's products, v^2 among them, leave the doubles' range); *error names the column otherwise.
  bool read(const std::vector<double>& row, State& state, std::string* error) const;
  /// Appends the state's values in names() order.
  static void write(const Model& model, const State& state, std::vector<double>& out, bool with_base_position = true);

 private:
  bool floating_ = false;
  std::vector<int> q_, v_, a_;
  int quat_[4] = {-1, -1, -1, -1}, w_[3] = {-1, -1, -1}, v_base_[3] = {-1, -1, -1}, dw_[3] = {-1, -1, -1},
      acc_[3] = {-1, -1, -1}, pos_[3] = {-1, -1, -1};
  std::vector<int> used_;            ///< every column read
  std::vector<std::string> header_;  ///< the bound table's names, for errors
};

}  // namespace exoid::tools
