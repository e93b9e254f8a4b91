#pragma once
// Subcommands of the exoid binary. Each returns the process exit code: 0 ok, 2 bad input or failure.
namespace exoid::cli {
int cmdModel(int argc, char** argv);
int cmdRegressor(int argc, char** argv);
int cmdBaseParams(int argc, char** argv);
int cmdExport(int argc, char** argv);
int cmdExperiment(int argc, char** argv);
int cmdIdentify(int argc, char** argv);
int cmdStudy(int argc, char** argv);
int cmdDiagnose(int argc, char** argv);
int cmdCalibrate(int argc, char** argv);
int cmdRender(int argc, char** argv);
}  // namespace exoid::cli
