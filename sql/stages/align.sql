-- stage: align (a stage of five files, each with its own contract header; run in this order)
--
-- trajdb: put N cameras into one frame and one clock from their tracks alone. Each camera's
-- points are in its own frame and on its own clock; at the end of this stage `points` is on the
-- reference camera's clock, `align_frames` holds every camera's transform into the reference
-- camera's frame and its clock t_camera = (1 + D) t_reference + O, and
-- merge_epsilon's rows are in `calibration`.
--
-- Method (why not the thesis's speed pre-match + CPD from R = I, see docs/alignment.md):
--  0. the coarse clock offset of each camera pair over every lag (activity cross-correlation);
--     no range is assumed;
--  1. every time-overlapping pair of tracks of the same class in two cameras is a hypothesis:
--     if both are the same road user, rigid_fit(traj_correspond(a, b, 0.5, dt)) recovers the
--     camera transform in closed form, whatever the rotation (no start needed), for the right
--     clock offset dt; each pair is fitted at every dt of a grid about the coarse offset (a
--     Hough line); a pair not settled there asks the road users' speed profiles, then searches
--     wider;
--  2. hypotheses vote in (theta, qx, qy, dt) bins about the cameras' centroids; true pairs
--     agree, wrong pairs scatter;
--  3. the tracks of all hypotheses that agree with the winning bin are refitted together, with
--     a trimmed least-squares fit at every dt of a fine grid around the winner; 3b. clock drift
--     from per-pair offsets under that transform, over the recording;
--  4. pairs with too little support are solved through other cameras: the widest path
--     (largest bottleneck support) to the reference camera, composing transforms and clocks.
-- Every time is relative to its camera's first time and every position vote to its camera's
-- centroid: moving a frame or shifting a clock changes nothing but that camera's result
-- (tests/test_invariance_python.py).
--
-- Parameters (align_*): declared once in crates/app/src/params.rs, defaults in sql/params.sql. Tracks
-- need >= align_min_points real points; pairs overlap >= align_min_overlap_s in time, give
-- >= align_min_pairs point pairs and their moving points span >= align_min_span_m; hypotheses
-- with residual < align_max_rms_m vote in bins of align_bin_deg degrees and align_bin_m metres;
-- a hypothesis agrees within align_agree_deg / align_agree_m; a camera pair needs
-- >= align_min_support agreeing hypotheses; the refit trims align_trim of the pairs, and the
-- second pass keeps track pairs within align_refine_rms_m RMS of the first fit.
--
--   align/coarse.sql    0. the coarse clock offset of every camera pair (activity cross-correlation)
--   align/vote.sql      1-2. hypotheses from track pairs over a grid of clock offsets, the vote, passes 2 and 3
--   align/refit.sql     3-3b. the joint refit of the agreeing pairs, the clock drift and the offset's standard error
--   align/register.sql  3c. the cleaned pairs, the final registration (register_pair), calib_match, merge_epsilon
--   align/frames.sql    4-5. the spanning tree, align_frames, calibration_summary, points on the reference clock
.read sql/stages/align/coarse.sql
.read sql/stages/align/vote.sql
.read sql/stages/align/refit.sql
.read sql/stages/align/register.sql
.read sql/stages/align/frames.sql
