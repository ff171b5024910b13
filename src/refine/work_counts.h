/* SPDX-License-Identifier: MIT
 * work_counts.h -- what a PKSS_COUNT_WORK build counts in the ICP's
 * nearest-neighbour lookups (correspond.c), and the call that reads the
 * counts. Self-contained: tools/identity/pkss_count.c includes it too.
 */
#ifndef PKSS_REFINE_WORK_COUNTS_H
#define PKSS_REFINE_WORK_COUNTS_H

enum pkss__work_count {
    PKSS_WORK_LOOKUPS = 0, /* nearest-partner lookups of the correspondences */
    PKSS_WORK_SINGLE,      /* ... answered by a lone kd-tree query (no memo) */
    PKSS_WORK_FIRST,       /* ... by a fresh query (the view's field, else the kd-tree),
                            * the memo empty (a run's first pass) */
    PKSS_WORK_MOVED,       /* ... by a fresh query, the point moved past its margin */
    PKSS_WORK_COUNTS
};

/* Copies the counts since the last call into out and resets them (all
 * threads' lookups; defined only in a PKSS_COUNT_WORK build). */
void pkss__work_counts(unsigned long out[PKSS_WORK_COUNTS]);

#endif
