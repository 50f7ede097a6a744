#!/bin/sh
# check_help.sh VERSION AUGER PROGRAM...: --help and --version of auger, of each of its subcommands
# (as `auger --help` lists them) and of each other PROGRAM. One line per problem; exit 1 if any.
version=$1
auger=$2
shift 2
fail=0
check() {  # check NAME CMD...: NAME is what --version must print before the version
  name=$1
  shift
  out=$("$@" --help 2>/dev/null)
  rc=$?
  if [ $rc -ne 0 ]; then echo "$name --help: exit $rc, not 0"; fail=1; fi
  case $out in *usage:*) ;; *) echo "$name --help: no usage on stdout"; fail=1 ;; esac
  out=$("$@" --version 2>/dev/null)
  rc=$?
  if [ $rc -ne 0 ] || [ "$out" != "$name $version" ]; then
    echo "$name --version: exit $rc, printed '$out', not '$name $version'"
    fail=1
  fi
}
check auger "$auger"
subcommands=$("$auger" --help | sed -n 's/^  auger \([a-z0-9-]*\) .*/\1/p')
[ -n "$subcommands" ] || { echo "auger --help lists no subcommand"; fail=1; }
n=0
for s in $subcommands; do
  check "auger $s" "$auger" "$s"
  n=$((n + 1))
done
for p in "$@"; do
  check "$(basename "$p")" "$p"
done
[ $fail -eq 0 ] && echo "cli_help: auger, its $n subcommands and $# other programs answer --help and --version"
exit $fail
