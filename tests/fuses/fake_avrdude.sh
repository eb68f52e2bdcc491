#!/bin/sh
# Stands in for avrdude in the fuses-check tests: answers "-U <mem>:r:-:h" with the value in
# FAKE_LFUSE / FAKE_HFUSE / FAKE_EFUSE / FAKE_LOCK (hex), in avrdude's output format, and
# records its arguments in FAKE_ARGS_FILE when set. FAKE_FAIL=1: no programmer answers.
[ -n "$FAKE_ARGS_FILE" ] && echo "$@" > "$FAKE_ARGS_FILE"
if [ "$FAKE_FAIL" = 1 ]; then
  echo "avrdude: stk500v2_ReceiveMessage(): timeout" >&2
  exit 1
fi
for arg in "$@"; do
  case "$arg" in
    lfuse:r:-:h) echo "${FAKE_LFUSE:-0xff}" ;;
    hfuse:r:-:h) echo "${FAKE_HFUSE:-0xd8}" ;;
    efuse:r:-:h) echo "${FAKE_EFUSE:-0xfd}" ;;
    lock:r:-:h) echo "${FAKE_LOCK:-0x0f}" ;;
  esac
done
exit 0
