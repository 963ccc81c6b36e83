#!/bin/sh
# CTest fixture cleanup: removes a generated sequence once every test that reads it has run,
# so a full ctest run never holds all its sequences (several GB of images) on disk at once.
# VIMS_KEEP_TEST_DATA=1 keeps them (to rerun a tool on a fixture by hand).
[ -n "$VIMS_KEEP_TEST_DATA" ] && exit 0
case "$1" in
  */test_data/*) rm -rf "$1" ;;
  *) echo "remove_sequence.sh: refusing to remove '$1' (not under test_data/)" >&2; exit 1 ;;
esac
