// States CSV reader (tools::readCsv) and the path of `exoid regressor` behind it: binding the columns to
// the exoskeleton (floating base) and the KUKA arm (fixed base), reading rows, evaluating the regressor.
// Properties: a rejection is one line; an accepted table has unique non-empty names and finite cells, one
// per header name in every row.
#include <cmath>
#include <cstdlib>
#include <set>
#include <string>

#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/csv.hpp"
#include "exoid/tools/state_columns.hpp"
#include "fuzz_support.hpp"

namespace {

exoid::Model g_models[2];

void loadModel(const std::string& path, bool floating, exoid::Model& model) {
  std::string error;
  if (!exoid::buildModelFromUrdfFile(path, floating, model, &error)) {
    std::fprintf(stderr, "fuzz_states_csv: %s\n", error.c_str());
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  loadModel(EXOID_CONFIG_DIR "/exo.urdf", true, g_models[0]);
  loadModel(EXOID_DATA_DIR "/kuka_lwr4/kuka_lwr4.urdf", false, g_models[1]);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static exoid::fuzz::MemFile file;
  exoid::tools::CsvTable table;
  std::string error;
  if (!exoid::tools::readCsv(file.write(data, size), table, &error)) {
    exoid::fuzz::checkOneLine(error, "a rejected CSV gets a one-line error");
    return 0;
  }
  EXOID_FUZZ_CHECK(!table.header.empty(), "an accepted table has a header");
  std::set<std::string> names;
  for (const std::string& h : table.header) {
    EXOID_FUZZ_CHECK(!h.empty(), "header names are non-empty");
    EXOID_FUZZ_CHECK(names.insert(h).second, "header names are unique");
  }
  for (const auto& row : table.rows) {
    EXOID_FUZZ_CHECK(row.size() == table.header.size(), "every row has one cell per column");
    for (double v : row) EXOID_FUZZ_CHECK(std::isfinite(v), "every cell is finite");
  }
  for (const exoid::Model& model : g_models) {
    exoid::tools::StateColumns columns;
    if (!columns.bind(model, table, &error)) {
      exoid::fuzz::checkOneLine(error, "an unbindable table gets a one-line error");
      continue;
    }
    exoid::Data kin(model);
    exoid::State state = exoid::State::zero(model);
    const size_t rows = std::min<size_t>(table.rows.size(), 16);  // bounded time per input
    for (size_t i = 0; i < rows; ++i) {
      if (!columns.read(table.rows[i], state, &error)) {
        exoid::fuzz::checkOneLine(error, "an unreadable row gets a one-line error");
        continue;
      }
      exoid::computeJointTorqueRegressor(model, kin, state);
      EXOID_FUZZ_CHECK(kin.K.allFinite(), "an accepted row gives a finite regressor");
    }
  }
  return 0;
}
