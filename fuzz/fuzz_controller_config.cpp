// Controller configuration (parseControllerConfig, YAML text). Properties: a rejection is one line naming
// the source; an accepted configuration passes the validation the controller relies on.
#include <string>

#include "exoid/controller/config.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string yaml(reinterpret_cast<const char*>(data), size);
  exoid::controller::ControllerConfig config;
  std::string error;
  if (!exoid::controller::parseControllerConfig(yaml, "fuzz.yaml", config, &error)) {
    exoid::fuzz::checkOneLine(error, "a rejected config gets a one-line error");
    EXOID_FUZZ_CHECK(error.rfind("fuzz.yaml", 0) == 0, "the error names the source");
    return 0;
  }
  EXOID_FUZZ_CHECK(exoid::controller::validateControllerConfig(config, &error), "accepted means valid");
  return 0;
}
