/* SPDX-License-Identifier: MIT
 * schedules.c -- the ICP schedules, defined once (values in src/tuning.h)
 * and shared by the stages and the tests.
 */
#include "refine/icp.h"

const pkss__icp_schedule pkss__schedule_coarse = PKSS_SCHEDULE_COARSE;
const pkss__icp_schedule pkss__schedule_full = PKSS_SCHEDULE_FULL;
const pkss__icp_schedule pkss__schedule_settle = PKSS_SCHEDULE_SETTLE;
const pkss__icp_schedule pkss__schedule_settle_fine = PKSS_SCHEDULE_SETTLE_FINE;
const pkss__icp_schedule pkss__schedule_polish = PKSS_SCHEDULE_POLISH;
