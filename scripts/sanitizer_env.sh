# The sanitizers' runtime options, sourced by scripts/sanitize.sh (the whole suite, gcc) and
# scripts/sanitized_subset.sh (CI's part, clang in build-fuzz/). Any report fails its test: UBSan does not recover,
# ASan aborts (abort_on_error: a test that spawns rgbdcast sees the child fail), LeakSanitizer reports at exit
# (detect_leaks: on, the default on x86_64 Linux, stated). The only suppressions are third-party findings, each with
# its reason, in tests/sanitizers/. The same options reach every child process through the environment.
# Usage: source scripts/sanitizer_env.sh ROOT   (ROOT: the repository's top folder)
sanitizer_root="$1"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=0:strict_string_checks=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$sanitizer_root/tests/sanitizers/ubsan.supp${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
export LSAN_OPTIONS="suppressions=$sanitizer_root/tests/sanitizers/lsan.supp:print_suppressions=0${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
export RGBDCAST_SANITIZED=1
