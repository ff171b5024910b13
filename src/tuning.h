/* SPDX-License-Identifier: MIT
 * tuning.h -- every constant the pipeline is tuned by, in pipeline order:
 * value, unit, and one line on why. The measurements behind each are in
 * docs/tuning.md (same names). Parameters a user may set are in the table
 * of src/common/context.c instead; this file holds what is fixed.
 *
 * The file is also the first part of the embedded OpenCL source (the
 * kernels use the search constants), so it holds #defines only.
 */
#ifndef PKSS_TUNING_H
#define PKSS_TUNING_H

/* ---- Validation (preshape/cloud.c) ----------------------------------- */
/* median radii around the median point within which the shape is judged:
 * a far sentinel must not make an object look collinear */
#define PKSS_CORE_RADII 100.0
/* points sampled (evenly) for the median point and radius */
#define PKSS_CORE_SAMPLE 4096
/* coordinate magnitudes whose squares would under/overflow the variance */
#define PKSS_MIN_MAGNITUDE 1e-150
#define PKSS_MAX_MAGNITUDE 1e150
/* relative eigenvalue at or below which the points are collinear/coplanar
 * (SPEC 1: "the cell partition is undefined") */
#define PKSS_FLAT_EIGEN 1e-12
/* extent below this share of the coordinate magnitude: identical points
 * up to rounding */
#define PKSS_MIN_EXTENT 1e-9

/* ---- Thinning (preshape/thin.c) --------------------------------------- */
/* bits per axis of a packed voxel key */
#define THIN_BITS 21
/* most passes of the voxel-size search */
#define THIN_MAX_PASSES 40
/* the voxel set holds about this many times target keys: counts beyond
 * only tell the search "too many", so its memory follows target, not n */
#define THIN_TRACK 3.5
/* most keys per slot of the open-addressing set (linear probing stays
 * short below ~0.7): 2^20 slots (16 MiB) at the default target */
#define THIN_LOAD 0.7
/* a count within target / THIN_CLOSE of target ends the search (5 %) */
#define THIN_CLOSE 20
/* the search starts as if the cloud were a surface of this share of its
 * box's face area (a sphere in its cube: pi/6; a flat scan: one face) */
#define THIN_AREA 0.5
/* points whose slots are prefetched before any is inserted: the set is
 * far larger than the caches */
#define THIN_BATCH 16

/* ---- Outlier culling (preshape/cull.c; k = PKSS_KNN_K) ---------------- */
/* culling sees at most this many points per resampled point (m), a seeded
 * uniform subset: its kNN statistics are relative to the density, which a
 * uniform subset keeps, and FPS still picks each of its m among about
 * that many (docs/tuning.md) */
#define PKSS_CULL_SUBSET 4
/* statistical filter (SPEC 2.3): far (d_i > STAT_FAR s_i) and off the
 * local plane (h_i > STAT_OFF_PLANE s_i; SPEC: 1.5), or sparse
 * (rho_i < STAT_SPARSE N / V): more box outliers go, no surface loss */
#define STAT_FAR 2.0
#define STAT_OFF_PLANE 2.0
#define STAT_SPARSE 0.1
/* a uniform background of lambda points per volume is the points sparser
 * than STAT_BG_KAPPA lambda: 12-NN densities of a Poisson set stay within
 * 4x of lambda (all but 0.1 %), surfaces lie far above (cull.c) */
#define STAT_BG_KAPPA 4.0
/* a background's count reaches this share of lambda V: an outlier beside
 * a surface counts that surface's points among its 12 neighbours */
#define STAT_BG_FILL 0.8
/* and the points it leaves are this much denser at their median (4x the
 * cut): a noisy small object's surface is not its own background */
#define STAT_BG_CONTRAST 16.0
/* steps of that estimate (it falls monotonically; speed) */
#define STAT_BG_STEPS 64
/* the density box: from the 0.5 % to the 99.5 % quantile, each side at
 * least this share of the longest (flat scans) */
#define STAT_QUANTILE 0.005
#define STAT_MIN_SIDE 0.02

/* ---- Resampling and kd-trees (preshape/resample.c, common/knn.c) ------ */
/* leaf size of the FPS bounding-volume tree (speed only) */
#define FPS_LEAF 32
/* kd-tree leaf size: ~4 % faster ICP queries than 10 (speed only) */
#define PKSS_KD_LEAF 16
/* a bound is "strictly farther" only beyond this relative slack: the
 * incremental box distance may exceed the exact one by a few ulps */
#define PKSS_KD_SLACK (1.0 - 0x1.0p-40)

/* ---- Features (preshape/cloud.c) -------------------------------------- */
/* k of the PCA neighbourhood (Eq. 3) for D_pca and the normals */
#define PKSS_KNN_K 12
/* the coarse view is m/PKSS_COARSE_DIV FPS points from this m on (all of
 * them below): a quarter keeps the coarse level's rims resolved */
#define PKSS_COARSE_MIN_M 1200
#define PKSS_COARSE_DIV 4

/* ---- Search (search/, kernels) ---------------------------------------- */
/* Coverage guard (SPEC 4.4): fewer matched cells, or a smaller share of
 * the template's occupied cells, gives G = pi/2 */
#define PKSS_MIN_MATCHED 4
#define PKSS_MIN_COVERAGE 0.2f
/* wide second search: share of the matched pairs the trimmed G keeps (the
 * cut rim's cells mislead the paper's G) */
#define PKSS_WIDE_KEEP 0.8f
/* ... and the share of the source's occupied cells it must match */
#define PKSS_WIDE_SRC_COVER 0.4f
/* bisection steps of the trimming threshold (ends within 2^-6) */
#define PKSS_TRIM_STEPS 6
/* the trimmed G keeps its pairs' residuals for the bisection up to this many
 * cells (the default partition's 72; 4.6 KB a 16-lane work-item); more are
 * recomputed in each pass (speed only) */
#define PKSS_TRIM_CACHE_CELLS 72
/* offset grid step = extent / this (Eq. 12: E/8) and, in the wide second
 * search, twice that step (E/4, reaching +-E/2) for a part's centroid */
#define PKSS_OFFSET_DIV 8.0
#define PKSS_WIDE_OFFSET_DIV 4.0
/* top-k suppression (SPEC 5): a candidate within this geodesic angle of a
 * kept one is dropped, so near-symmetric minima do not crowd the list */
#define PKSS_TOPK_SUPPRESS_DEG 45.0
/* entries within this make two Euler-grid rotations one (Eq. 10 repeats) */
#define PKSS_SAME_ROTATION_TOL 1e-9

/* ---- Refinement: which candidates (refine/stages.c) ------------------- */
/* candidates started together on the coarse level before the rest: if
 * one covers both clouds the others are only scored */
#define PKSS_FIRST_WAVE 2
/* candidates fully refined by coarse overlap ... */
#define PKSS_FULL_REFINE 3
/* ... unless below this share of the best coarse overlap */
#define PKSS_FULL_REFINE_RATIO 0.6
/* coarse overlap at which a candidate covers both clouds (complete
 * objects reach 0.98-1.0, partial scans stay far below) */
#define PKSS_COARSE_COMPLETE 0.98
/* share of one cloud within the fit distance of the other at which a refined
 * candidate explains it wholly (the same 2 % allowance) */
#define PKSS_EXPLAINED 0.98
/* |f_s - f_t| above which one cloud shows a part of the other, so the
 * pre-shape scale ratio is off (SPEC 6 caveat) */
#define PKSS_PART_OF_WHOLE 0.05
/* coverage from which the part lies wholly on the other cloud */
#define PKSS_PART_COVERED 0.9
/* fit / overlap from which a refined candidate lies on the template in
 * contact (its overlapping points within the fit distance, not merely
 * near): it ends its search's full runs */
#define PKSS_CONTACT 0.9
/* fit / overlap from which the winner has placed the part: the searches for
 * its place (wide, local, shift) do not run. Below PKSS_CONTACT, as a winner beat
 * every refined candidate: wrong winners that a later search beat read
 * <= 0.73, scans' right ones 0.80-1.00 */
#define PKSS_PLACED 0.85
/* scale search moves (log of the factor): coarse views, then all points,
 * as the coarse tolerance cannot place the scale to 3 % */
#define PKSS_SCALE_STEP_COARSE 0.10
#define PKSS_SCALE_STEP_FINE 0.03
/* most moves of one scale search */
#define PKSS_SCALE_MOVES 4
/* merits (pkss__icp_merit; the slide search: fits) closer than this (~10
 * of 3000 points) are a tie; the lower RMS breaks it */
#define PKSS_OVERLAP_TIE 0.003
/* Same basin before a full run (refine/basin.c): within these, full
 * refinement would take the second pose where it took the first */
#define PKSS_START_BASIN_DEG 5.0
#define PKSS_START_BASIN_SCALE 0.05
#define PKSS_START_BASIN_H 5.0
/* Same basin during a run: distinct minima lie >= 15 degrees apart, two
 * runs into one creep toward it 1-1.5 degrees apart */
#define PKSS_RUN_BASIN_DEG 3.0
#define PKSS_RUN_BASIN_SCALE 0.01
#define PKSS_RUN_BASIN_H 1.0
/* slide search range, share of the template's extent either way (box
 * parts slide by 8-14 % of the diameter) */
#define PKSS_SLIDE_RANGE 0.2
/* points between a bounded fit's tests of whether it can still reach its
 * bar (correspond.c:pkss__fit_reaching; speed only) */
#define PKSS_FIT_BLOCK 64
/* translation search at the winner's rotation and scale (shift_search.c):
 * vote cells of 2 template spacings, coarsened to at most 16 cells either
 * way (bounds the peak scan); translations up to a quarter of the
 * template's bounding-box diagonal (a wall's width in a room scan); the
 * best 3 distinct peaks with more than 95 % of the held translation's votes
 * are refined: between two partial views the truth can cover less than a
 * slid pose, and the merit picks (docs/tuning.md) */
#define PKSS_SHIFT_CELL 2.0
#define PKSS_SHIFT_MAX_R 16
#define PKSS_SHIFT_RANGE 0.25
#define PKSS_SHIFT_TRIALS 3
#define PKSS_SHIFT_SHARE 0.95
/* the shift search from other rotations (stages.c:pkss__stage_reshift): a
 * winner with less than 0.6 of its overlap within the fit distance is held
 * near the template, not on it (docs/tuning.md: set on pairs that share
 * their points); the 5 best-merit candidates at other rotations each vote,
 * and of their 12 best peaks above half the held votes the 2 best by merit
 * on all points as they stand are settled there, whose fit ranks them where
 * coverage and coarse views cannot (2: the winning peak is not always the
 * best unsettled one) */
#define PKSS_ASTRAY 0.6
#define PKSS_RESHIFT_SOURCES 5
#define PKSS_RESHIFT_PEAKS 12
#define PKSS_RESHIFT_SHARE 0.5
#define PKSS_RESHIFT_SETTLED 2
/* the scale sweep at the winner's rotation (stages.c:pkss__stage_rescale):
 * where both clouds are parts, the overlap-driven scale stages can draw one
 * into the other's outline; the scales from the winner's toward the
 * pre-shape ratio, in steps of 15 % (within half a step, 7 %, a full
 * run's scale stage takes over), at most 4 (a factor of 1.75), each vote
 * as the other rotations' do */
#define PKSS_RESCALE_STEP 1.15
#define PKSS_RESCALE_STEPS 4
/* the vote's blocks of template points: 4 cells a side (a source point's
 * reach spans ~4 of them each way); the grid's coarsening keeps them to
 * 17 per axis, the cap of 32 only bounds memory; they order the work, the
 * votes are the same */
#define PKSS_SHIFT_BLOCK 4.0
#define PKSS_SHIFT_MAX_BLOCKS 32.0

/* local-feature starts where both clouds are parts (local_match.c): FPFH
 * over the 16 nearest coarse points (~2 coarse spacings, then twice that
 * through the neighbours' histograms), 11 bins per angle (Rusu 2009);
 * samples of 3 matches: at least 4000 (a 10 % inlier share), and as many
 * as find the least evidence below (8 inliers of n matches) with 98 % odds,
 * at most 100 000 (~10-50 ms); a sample's
 * edges agree to 10 % and span >= 3 spacings; the scale within [1/2, 2]
 * (both clouds have unit RMS radius); a match within 2 spacings is an
 * inlier, 8 of them the least evidence; the 8 best basins refitted, the
 * best PKSS_LOCAL_STARTS of them refined */
#define PKSS_LOCAL_K 16
#define PKSS_LOCAL_BINS 11
#define PKSS_LOCAL_SAMPLES 4000
#define PKSS_LOCAL_ODDS 0.98
#define PKSS_LOCAL_SAMPLES_MAX 100000
#define PKSS_LOCAL_EDGE_TOL 0.1
#define PKSS_LOCAL_MIN_EDGE 3.0
#define PKSS_LOCAL_SCALE_MAX 2.0
#define PKSS_LOCAL_REACH 2.0
#define PKSS_LOCAL_MIN_INLIERS 8
#define PKSS_LOCAL_KEPT 8
#define PKSS_LOCAL_STARTS 3

/* ---- Trust: alternatives, symmetry, confidence (refine/assess.c) ------ */
/* The logistic model's coefficients are generated by tools/confidence/fit.py
 * into refine/confidence_model.h (data and seeds in its header). */
/* Two fits within this many binomial standard deviations of the winner's
 * (sqrt(f (1 - f) / m)) cannot be told apart ... */
#define ASSESS_NOISE_SIGMAS 3.0
/* ... nor within this absolute floor: resampling alone moves a fit by ~0.01. */
#define ASSESS_NOISE_FLOOR 0.015
/* A pose whose points fall between the target's samples reads about
 * 0.88-0.92 at 1 spacing even where it lies on the surface (every symmetric
 * image; an exact copy's truth reads 1.0): ties are judged against the
 * winner's fit or this, whichever is lower. */
#define ASSESS_DECORRELATED_FIT 0.90
/* A turned pose or a candidate short of full refinement whose fit comes
 * this close to a tie gets a rigid polish before it is judged. */
#define ASSESS_POLISH_MARGIN 0.10
/* A continuous-symmetry turn that the polish moves by more than this
 * (radians, 3 degrees) snapped back to a discrete symmetry. */
#define ASSESS_SNAP 0.05
/* A turn whose fit on the coarse views (a quarter of the points, their own
 * spacing) stays this far below a tie is not measured on all points. */
#define ASSESS_COARSE_MARGIN 0.25
/* PCA variances of the target closer than this (relative) may hide a
 * continuous symmetry about the third axis: only then is it tested. */
#define ASSESS_EIG_EQUAL 0.15
/* Largest order n of a 360/n-degree turn tried about such an axis. */
#define ASSESS_MAX_ORDER 8
/* A turn that takes the shape's axis onto itself within this angle is
 * explained by an axial symmetry (cos of 10 degrees). */
#define ASSESS_AXIS_COS 0.985
/* The margin feature saturates here: beyond it, more margin tells nothing. */
#define ASSESS_MARGIN_CAP 0.3
/* The RMS feature (in spacings) saturates here. */
#define ASSESS_RMS_CAP 5.0
/* Turn angles of the continuous-symmetry test: >= 15 degrees from every
 * multiple of 360/n for n = 2..8, so no discrete symmetry passes them. */
#define ASSESS_CONTINUOUS_TEST_DEG {22.5, 167.0}


/* ---- Refinement: the ICP engine (refine/icp.c) ------------------------ */
/* gate decay per iteration and its floor, in h (SPEC 6) */
#define ICP_GATE_DECAY 0.85
#define ICP_GATE_FLOOR 3.0
/* relative slack for "the gate is at its floor" against rounding */
#define ICP_FLOOR_SLACK 1.000001
/* gate reopened to this (h) when the scale is freed */
#define ICP_GATE_SCALE_START 8.0
/* relative scale change per iteration below which the scale has settled */
#define ICP_SCALE_SETTLED 1e-4
/* pose change (pose_change) below which a stage has converged */
#define ICP_CONVERGED 1e-6
/* fewer pairs keep the pose (SPEC 6) */
#define ICP_MIN_PAIRS 10
/* a rigid stage keeps a pair whose partner lies beneath its point: the
 * offset along the partner's surface within this share of the gate (1.5 h
 * at the floor); beyond the other cloud's rim the nearest partner lies
 * beside the point, on the rim, and pulls the rims together */
#define ICP_BENEATH 0.5
/* coverage distance, in spacings (the coarser cloud's) */
#define ICP_OVERLAP_DIST 2.0
/* the fit's distance: a box part turned 180 degrees covers as much within
 * 2 spacings as the truth, but lies on it less closely */
#define ICP_FIT_DIST 1.0
/* iterations over which a stage's overlap gain is projected */
#define ICP_GAIN_WINDOW 5
/* overlap gain over the window below which a rigid stage has settled
 * (3 of 3000 points) ... */
#define ICP_STAGNANT 1e-3
/* ... while its pose moves less than this per iteration (~1/30 h) */
#define ICP_SETTLED_MOVE 2e-3
/* point-to-plane: largest step (rad / relative scale / pre-shape units;
 * pairs lie within 3h) and the step below which it has settled */
#define ICP_PLANE_MAX_STEP 0.05
#define ICP_PLANE_SETTLED 1e-4
/* relative damping of the point-to-plane normal equations: a free
 * direction (a plane's sliding) stays where it is */
#define ICP_PLANE_DAMPING 1e-6
/* the winner's last point-to-plane steps (refine/fine.c) pair its points
 * with the template's culled points (not resampled) within this many of
 * their spacings: wider pairs reach past the edge of a partial overlap and
 * pull the scale (docs/tuning.md) ... */
#define PKSS_FINE_GATE 1.5
/* ... or within this many sigmas of the contact's noise (1.4826 x the
 * median point-to-plane distance of the pairs within the ICP's floor gate),
 * if wider: a gate inside the noise cuts its tails unevenly ... */
#define PKSS_FINE_NOISE_SIGMAS 2.0
/* ... for at most this many steps, as the polish of a run */
#define PKSS_FINE_ITERS 30
/* relative slack of a remembered nearest neighbour's test, far above the
 * rounding of the distances it compares */
#define ICP_MEMO_SLACK 1e-9
/* a fresh nearest-neighbour query remembers this many neighbours less one;
 * the last one's distance is the margin (docs/tuning.md) */
#define ICP_MEMO_K 4
/* a fresh query looks this many gates far: beyond, it only bounds the
 * margin (speed only) */
#define ICP_MEMO_REACH 2.0

/* The nearest-neighbour field (common/nn_field.c): cube side in spacings
 * of the view; larger cubes are fewer to build but longer to read */
#define PKSS_FIELD_CELL 3.0
/* cubes farther than this many sides from every point keep no list (it
 * would grow with the distance), only that distance as the bound */
#define PKSS_FIELD_FAR 2.0
/* points a list may hold (more: the cube keeps only its bound) */
#define PKSS_FIELD_MAX_LIST 512
/* nearest points a query may return, plus one */
#define PKSS_FIELD_MAX_KEEP 8
/* hash slots (2^bits, at most half of them cubes) and linear probes: a
 * full table leaves new cubes to the tree */
#define PKSS_FIELD_SLOT_BITS 14
#define PKSS_FIELD_PROBES 16
/* list entries (32 bytes) per field, 4 MB: memory stays bounded, a full
 * pool leaves new cubes to the tree */
#define PKSS_FIELD_POOL_ENTRIES (1u << 17)

/* ---- ICP schedules (refine/schedules.c; fields of pkss__icp_schedule) - */
/* coarse level on every candidate: the search is ~10-20 degrees accurate,
 * a 12h gate covers the rim's displacement at the coarse spacing */
#define PKSS_SCHEDULE_COARSE {.gate_start = 12.0, .rigid_iters = 14, .max_iters = 14}
/* full run: the rigid stage ends once settled (<= 60), a part's scale
 * converges slowly from ~20 % off (200 in all), the point-to-plane
 * polish is bounded as it can creep on box parts (30) */
#define PKSS_SCHEDULE_FULL {.gate_start = 6.0, .rigid_iters = 60, .max_iters = 200, \
                            .free_scale = PKSS__SCALE_MUTUAL, .plane_iters = 30}
/* the rigid settle after each trial scale of a scale search: 5h to the floor */
#define PKSS_SETTLE_GATE 5.0
#define PKSS_SCHEDULE_SETTLE {.gate_start = PKSS_SETTLE_GATE, .rigid_iters = 10, .max_iters = 10}
/* the same on all points after a 3 % step, which moves points a third as far
 * as the coarse views' 10 %: to the floor and 2 steps there, enough to rank
 * the trials (the full run converges the best) */
#define PKSS_SCHEDULE_SETTLE_FINE {.gate_start = PKSS_SETTLE_GATE, .rigid_iters = 6, \
                                   .max_iters = 6}
/* the rigid polish of a near tie before it is judged (refine/assess.c):
 * a turned pose settled on all points, as the winner was */
#define PKSS_SCHEDULE_TIE_POLISH {.gate_start = 4.0, .rigid_iters = 12, .max_iters = 12}
/* the slide search's polish: point-to-plane steps only, from the shift */
#define PKSS_SCHEDULE_POLISH {.gate_start = ICP_GATE_FLOOR, .plane_iters = 30}

/* ---- OpenCL lanes and work-groups (search/evaluate_cl.c:group_shape) --- */
/* lanes per work-item on CPUs (AVX-512: 16 floats); 1 on GPUs (SIMT) */
#define PKSS_VW_CPU 16
/* CPU groups: a group runs on one core (PoCL needs 8-64) */
#define PKSS_WG_SCORE_CPU 8
#define PKSS_WG_BIN_CPU 8
/* GPU groups: a multiple of SIMT widths 32 and 64; fewer binning items */
#define PKSS_WG_SCORE_GPU 128
#define PKSS_WG_BIN_GPU 64

/* ---- Threads and progress (common/) ----------------------------------- */
/* queries below which the second thread costs more than it saves (a
 * hand-over costs ~1 us with the spins, 750 queries 30-60 us) */
#define ICP_THREAD_MIN 300
/* lookups a thread claims at a time in a correspondence pass (~5-40 us of
 * work: the claims cost nothing beside it; speed only) */
#define PKSS_LOOKUP_CHUNK 128
/* dense-view planes a thread claims at a time (~0.2 ms of work; speed
 * only) */
#define PKSS_PLANES_CHUNK 512
/* seconds a thread spins for a hand-over before it sleeps: ICP iterations
 * hand over every few hundred us, a wake-up costs 20-60 us (helper.c) */
#define PKSS_HELPER_SPIN 100e-6
/* seconds between the caller's progress ticks while it waits */
#define PKSS_WAIT_TICK 0.01
/* seconds between progress callbacks within one stage */
#define PKSS_PROGRESS_INTERVAL 0.02

#endif
