// `exoid diagnose` end to end on the real KUKA LWR4+ runs (identify on runs 2 and 3, validate on run 1): the
// regression numbers with a margin, the findings a reader can check in the data (torque offset on the
// vertical first joint, Coulomb friction), the sidecar and report; bad input exits 2 with one line.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <cmath>
#include <string>

#include "exoid/estimator/diagnose.hpp"
#include "exoid/model/urdf.hpp"
#include "support/paths.hpp"
#include "support/run_command.hpp"

namespace exoid {
namespace {

std::string kukaArgs() {
  const std::string d = test::dataPath("kuka_lwr4/");
  return " --model " + d + "kuka_lwr4.urdf --train " + d + "measurements_2.csv " + d + "measurements_3.csv --validate " + d +
         "measurements_1.csv";
}

TEST(DiagnoseCli, KukaLwr4HeldOutRmseAndFindings) {
  test::TempDir dir("diagnose_kuka");
  const std::string out = dir.file("out");
  const test::CommandResult r = test::runCommand(test::exoidBinary() + " diagnose" + kukaArgs() + " --no-plots --out " + out, dir.path);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json js = nlohmann::json::parse(test::slurp(out + "/summary.json"));
  // A plain rigid-body OLS fit leaves 0.730 N m on run 1 (independently: numpy lstsq on `exoid regressor`
  // output, the 70 rigid columns); the augmented model must reach the 0.26 N m (measured 0.2520 with the kind rule of stop 7; 0.2564 before).
  EXPECT_NEAR(js["pooled_rmse_before"].get<double>(), 0.730, 0.002);
  EXPECT_LE(js["pooled_rmse_after"].get<double>(), 0.26);
  for (const auto& c : js["coordinates"]) EXPECT_LT(c["rmse_after"].get<double>(), c["rmse_before"].get<double>()) << c["name"];
  // The offset of the first joint (vertical axis: gravity cannot explain a constant torque there) is
  // 0.83 N m in every run (mean residual of the plain fit on runs 1, 2, 3: 0.84, 0.83, 0.81).
  bool offset0 = false;
  int coulomb = 0;
  for (const auto& f : js["findings"]) {
    if (f["joint"] == "lwr_0_joint" && f["kind"] == "offset") offset0 = std::abs(f["value"].get<double>() - 0.83) < 0.05;
    if (f["kind"] == "coulomb") ++coulomb;
  }
  EXPECT_TRUE(offset0) << js["findings"].dump(1);
  EXPECT_GE(coulomb, 3);
  // A kind the held-out folds do not tell from the chosen one is named beside it (docs/diagnose.md "Selection" step
  // 4), in summary.json and the sentence alike: another family on the same joint, its test failed at alpha (or, beside
  // a coupling, the strongest candidate on the joint whose angle it reads, with whose candidates in the model the
  // coupling is not significant). On these runs joints that mostly turn one way give offset-or-Coulomb and
  // Coulomb-or-viscous pairs (4 of the 16 findings, measured; the couplings of lwr_2 on lwr_3's angle and lwr_0 on
  // lwr_1's stay significant with lwr_3's and lwr_1's candidates in, p = 1e-5 and 3e-7).
  const auto family = [](const std::string& k) {
    return k.rfind("elastic", 0) == 0 ? std::string("elastic") : k == "stribeck" ? std::string("coulomb") : k;
  };
  const std::string md = test::slurp(out + "/report.md");
  int named_with_alternative = 0;
  for (const auto& f : js["findings"]) {
    const std::string sentence = f["sentence"];
    EXPECT_NE(md.find(sentence), std::string::npos) << sentence;
    if (!f.contains("or")) {
      EXPECT_EQ(sentence.find("; or "), std::string::npos) << sentence;
      continue;
    }
    ++named_with_alternative;
    const auto& a = f["or"];
    if (a["joint"] == f["joint"]) {
      EXPECT_NE(family(a["kind"]), family(f["kind"])) << f.dump();
    } else {  // a coupling's alternative on its angle's joint, said so in words
      EXPECT_TRUE(f.contains("angle_of") && a["joint"] == f["angle_of"] &&
                  sentence.find("on " + a["joint"].get<std::string>() + " (its strongest candidate)") !=
                      std::string::npos) << f.dump();
    }
    EXPECT_GE(a["separation_p"].get<double>(), 0.01) << f.dump();
    EXPECT_GT(a["gain_ratio"].get<double>(), 0.0) << f.dump();
    EXPECT_TRUE(std::isfinite(a["value"].get<double>())) << f.dump();
    EXPECT_NE(sentence.find("; or "), std::string::npos) << sentence;
    if (a["kind"] != "gain" && a["kind"] != "delay") {  // those two are written in % and ms
      EXPECT_NE(sentence.find(a["unit"].get<std::string>(), sentence.find("; or ")), std::string::npos) << sentence;
    }
  }
  EXPECT_GE(named_with_alternative, 1) << js["findings"].dump(1);
  // The sidecar reads back into the same effects.
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfFile(out + "/kuka_lwr4.urdf", false, model, &err)) << err;
  estimator::EffectSet set;
  ASSERT_TRUE(estimator::readEffects(out + "/effects.yaml", model, set, &err)) << err;
  EXPECT_EQ(set.effects.size(), js["findings"].size());
  // The sidecar into `exoid identify --effects` (known corrections): the training residual of the rigid body +
  // viscous + hard-sign Coulomb model falls when the found offsets, Stribeck terms and gains are applied.
  const std::string d = test::dataPath("kuka_lwr4/");
  const std::string id = test::exoidBinary() + " identify --fixed-base --model " + d + "kuka_lwr4.urdf --data " + d +
                         "measurements_2.csv " + d + "measurements_3.csv --rank full --method OLS";
  const test::CommandResult plain = test::runCommand(id + " --out " + dir.file("id_plain"), dir.path);
  const test::CommandResult with = test::runCommand(id + " --effects " + out + "/effects.yaml --out " + dir.file("id_eff"), dir.path);
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  ASSERT_EQ(with.exit_code, 0) << with.err;
  const double rmse_plain = nlohmann::json::parse(test::slurp(dir.file("id_plain/summary.json")))["training"]["rmse"];
  const double rmse_with = nlohmann::json::parse(test::slurp(dir.file("id_eff/summary.json")))["training"]["rmse"];
  EXPECT_LT(rmse_with, 0.9 * rmse_plain) << rmse_plain << " -> " << rmse_with;
  const std::string report = test::slurp(out + "/report.md");
  EXPECT_NE(report.find("lwr_0_joint: constant torque offset"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(out + "/residual_measurements_1.csv"));
  // The last stage: after augmentation the residual is still predictable from the state on some joints (the issue's
  // hysteresis loops; measured: lwr_0, lwr_4, lwr_5, lwr_6 at 49-95 %), each named with its own joint's state among
  // the variables and never with a candidate's name; lwr_6's is nearly all predictable (95 % sparse, 93 % trees).
  const nlohmann::json& pr = js["predictability"];
  ASSERT_TRUE(pr["ran"].get<bool>());
  EXPECT_TRUE(pr["has_q"].get<bool>());  // q reached the stage through Segment::stream_state
  int named = 0;
  for (const auto& j : pr["joints"]) {
    if (!j["predictable"].get<bool>()) continue;
    ++named;
    const std::string joint = j["joint"];
    bool own = false;
    for (const auto& v : j["variables"]) {
      const std::string name = v["name"];
      own = own || name.substr(name.find('_') + 1) == joint;
    }
    EXPECT_TRUE(own) << j.dump(1);
    const std::string sentence = j["sentence"];
    EXPECT_EQ(sentence.rfind("an effect the model lacks on " + joint, 0), 0u) << sentence;
    for (const char* kind : {"friction", "offset", "armature", "gain", "delay"})
      EXPECT_EQ(sentence.find(kind), std::string::npos) << sentence;
    if (joint == "lwr_6_joint") {
      EXPECT_GT(j["share"].get<double>(), 0.8);
    }
  }
  EXPECT_GE(named, 1);
  EXPECT_NE(report.find("## Is the remaining residual predictable from the state?"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(out + "/predictability.csv"));
}

// Every number summary.json holds, compared leaf by leaf (names of the files aside, which follow the order given).
void expectSameFigures(const nlohmann::json& a, const nlohmann::json& b, const std::string& where, int* compared) {
  ASSERT_EQ(a.type(), b.type()) << where;
  if (a.is_number()) {
    ++*compared;
    EXPECT_NEAR(a.get<double>(), b.get<double>(), 1e-9) << where;
  } else if (a.is_object()) {
    for (auto it = a.begin(); it != a.end(); ++it) {
      if (it.key() == "train" || it.key() == "segment") continue;  // the files, in the order given
      ASSERT_TRUE(b.contains(it.key())) << where << "." << it.key();
      expectSameFigures(it.value(), b[it.key()], where + "." + it.key(), compared);
    }
  } else if (a.is_array()) {
    ASSERT_EQ(a.size(), b.size()) << where;
    for (size_t i = 0; i < a.size(); ++i) expectSameFigures(a[i], b[i], where + "[" + std::to_string(i) + "]", compared);
  }
}

// The order of the --train files changes no figure (issue 18 item 2): the online comparison once counted ticks from
// zero in each file, so RecursiveLs refused every later file's rows as duplicates and the "online" figures came from
// the first file alone (0.4530 for 2 3 and for 2 alone, 0.5021 for 3 2).
TEST(DiagnoseCli, TrainingFileOrderChangesNoFigure) {
  test::TempDir dir("diagnose_order");
  const std::string d = test::dataPath("kuka_lwr4/");
  const std::string base = test::exoidBinary() + " diagnose --no-plots --model " + d + "kuka_lwr4.urdf --validate " + d + "measurements_1.csv";
  const test::CommandResult a = test::runCommand(base + " --train " + d + "measurements_2.csv " + d + "measurements_3.csv --out " + dir.file("a"), dir.path);
  const test::CommandResult b = test::runCommand(base + " --train " + d + "measurements_3.csv " + d + "measurements_2.csv --out " + dir.file("b"), dir.path);
  ASSERT_EQ(a.exit_code, 0) << a.err;
  ASSERT_EQ(b.exit_code, 0) << b.err;
  const nlohmann::json ja = nlohmann::json::parse(test::slurp(dir.file("a/summary.json")));
  const nlohmann::json jb = nlohmann::json::parse(test::slurp(dir.file("b/summary.json")));
  ASSERT_TRUE(ja.contains("online_joint_rmse_before")) << "no online figure to compare";
  int compared = 0;
  expectSameFigures(ja, jb, "summary", &compared);
  EXPECT_GT(compared, 50);
}

TEST(DiagnoseCli, BadInputExitsTwoWithOneLine) {
  test::TempDir dir("diagnose_bad");
  const std::string d = test::dataPath("kuka_lwr4/");
  test::CommandResult r = test::runCommand(test::exoidBinary() + " diagnose --model " + d + "kuka_lwr4.urdf --train " +
                                               dir.file("missing.csv") + " --out " + dir.file("o"), dir.path);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("missing.csv"), std::string::npos) << r.err;
  r = test::runCommand(test::exoidBinary() + " diagnose" + kukaArgs() + " --effects magic --out " + dir.file("o"), dir.path);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("magic"), std::string::npos) << r.err;
  r = test::runCommand(test::exoidBinary() + " diagnose" + kukaArgs() + " --alpha 2 --out " + dir.file("o"), dir.path);
  EXPECT_EQ(r.exit_code, 2);
  // A calibration run (pelvis held in a harness) belongs to a floating-base robot: refused on the fixed-base arm.
  r = test::runCommand(test::exoidBinary() + " diagnose" + kukaArgs() + " --calibration " + d + "measurements_1.csv --out " +
                           dir.file("o"),
                       dir.path);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--calibration and --validate-calibration need --floating-base"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;  // one line
}

}  // namespace
}  // namespace exoid
