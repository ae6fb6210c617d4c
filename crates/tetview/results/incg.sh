#!/bin/bash
# incg.sh LIMIT_GB CMD...: runs CMD in the cgroup v1 memory cgroup tetkit_test (created
# here if missing; needs root) limited to LIMIT_GB GiB.
mkdir -p /sys/fs/cgroup/memory/tetkit_test
echo $(( $1 * 1024 * 1024 * 1024 )) > /sys/fs/cgroup/memory/tetkit_test/memory.limit_in_bytes
shift
echo $$ > /sys/fs/cgroup/memory/tetkit_test/cgroup.procs
exec "$@"
