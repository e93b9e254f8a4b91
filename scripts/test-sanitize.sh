#!/usr/bin/env bash
# Builds build-sanitize/ (clang, AddressSanitizer + UndefinedBehaviorSanitizer on every target, every report
# fatal) and runs the unit tests in it. Excluded (docs/testing.md): label `system` (multi-process runs of
# minutes), ClosedLoopMujoco.FullTwentyMoveProtocol and ModelError.RandomUndeclaredEffectsKeepBalance (20-move
# in-process loops, minutes under ASan; the four-move closed-loop tests run the same code) and the seven
# Kinds/SingleEffect diagnosis cases (13-20 s each under ASan; TwoEffects and the clean cases run the same code),
# and more (docs/testing.md lists them with where their code runs sanitized). The system tests are not even
# built there (tests/CMakeLists.txt). Arguments are passed to ctest.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/scripts/build-sanitize.sh"
# Leaks are errors (except urdfdom's own, fuzz/lsan.supp); UBSan prints the stack.
export LSAN_OPTIONS="suppressions=$here/fuzz/lsan.supp:print_suppressions=0${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
export ASAN_OPTIONS="detect_leaks=1:strict_init_order=1:check_initialization_order=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
cd "$here/build-sanitize"
ctest --output-on-failure -j "$(nproc)" -LE '^system$' -E '^(ClosedLoopMujoco\.(FullTwentyMoveProtocol|FourMovesWithEncoderNoise|FourMovesTrackCoMWithoutSlipOrFall|BentKneeStartAlsoTracksVerticalMoves)|ModelError\.RandomUndeclaredEffectsKeepBalance|Kinds/SingleEffect\..*|OnlineEstimator\..*|OnlineEffects\.Sidecar.*|DiagnoseCli\.(KukaLwr4HeldOutRmseAndFindings|TrainingFileOrderChangesNoFigure)|EstimateClosedLoop\.TrueComTracksTheReferenceTwiceAsWellUnderAnUndeclaredPayload|Diagnose\.(CleanDataGiveNoFinding|CandidatesInTheDeclaredSpanAreNotTested|TheCoulombWidthIsProfiledPerJoint)|ConsistentExo\.ConsistentWhereLeastSquaresIsNot|BatchSolvers\.EveryMethodAtEveryRankEqualsTheDenseSvdOfTheStackedProblem|RecursiveLs\.TenMillionUpdatesStayPositiveDefiniteAndFinite|DamagedLogCommands\..*|PayloadCli\.(KukaSyntheticPayloadIsNamedByDiagnoseAndReidentifiedByOnlyLinks|WithoutADeclaredModelThePayloadIsReportedAsAbsorbed)|RankRule\.(DefaultIsWithinTenPercentOfTheValidationChoiceOnSyntheticArms|FrictionDominantArmWithAZeroFrictionPriorKeepsTheFrictionDirections|HeldOutToTrainingRatioWarnsWhenTheValidationRunCarriesALoad)|ResidualPredictability\.NoiseIndependentOfTheStateIsNeverNamed)$' --timeout 900 "$@"
