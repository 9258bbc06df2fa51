#include <valgrind/callgrind.h>
void cg_start(void){ CALLGRIND_START_INSTRUMENTATION; CALLGRIND_ZERO_STATS; }
void cg_stop(void){ CALLGRIND_DUMP_STATS_AT("cand"); CALLGRIND_STOP_INSTRUMENTATION; }
void cg_on(void){ CALLGRIND_START_INSTRUMENTATION; }
void cg_off(void){ CALLGRIND_STOP_INSTRUMENTATION; }
void cg_zero(void){ CALLGRIND_ZERO_STATS; }
void cg_dump(void){ CALLGRIND_DUMP_STATS_AT("part"); }
