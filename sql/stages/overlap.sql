-- stage: overlap
-- reads: points, calib_camera_order, calib_cameras, align_frames
-- makes: view_polygons, view_overlaps, view_merge_order, view_overlaps_chain
-- work: view_points
-- changes: -
-- parameters: overlap_concavity, overlap_method, overlap_min_neighbours, overlap_radius_m,
--             overlap_shrink_sigmas
--
-- trajdb: camera view polygons and their overlaps, per class, in the common frame
-- (thesis 2.3: P^k, P^{k∩l}, and (P^{k1} ∪ … ∪ P^{k(i-1)}) ∩ P^{ki} for a merge order).
--
-- Input: `points(camera, track_id, class, t, x, y, estimated)` in camera-local frames and
-- `align_frames(camera, reference, to_reference, ...)` from sql/stages/align.sql.
-- Output tables (polygons are WKB BLOBs; polygon_to_wkt() reads them, and DuckDB spatial's
-- ST_GeomFromWKB() takes them as they are):
--   view_polygons(camera, class, polygon, area_m2, n_points)        P^k; class '*' = all classes
--   view_overlaps(class, cam_a, cam_b, polygon, area_m2)            P^a ∩ P^b, a < b
--   view_overlaps_chain(class, merged, camera, polygon, area_m2)    (∪ P^merged) ∩ P^camera
--                                                                   along the merge order
-- Cameras that align.sql could not place are left out (they have no row in align_frames).
--
-- Parameters (see above):
--   hull method 'convex' (default: a camera's field of view is convex) or 'concave' + concavity;
--   robust rule: estimated points are dropped, and a point counts only with >= 3 other points
--   within 2 m (spurious detections are isolated; 10 Hz tracks leave dense trails);
--   noise correction: the hull of noisy points overshoots the true view edge, so each P^k is
--   shrunk by overlap_shrink_sigmas x the camera's position noise, measured from its own tracks
--   (calib_cameras.sigma_m, sql/stages/calibrate.sql; 0 switches the correction off);
--   merge order: the cameras' data order (calib_camera_order: camera ids are labels; the table
--   view_merge_order can be replaced).
-- Parameters (overlap_*): declared once in crates/app/src/params.rs, defaults in sql/params.sql;
-- `trajdb params` lists them, `trajdb pipeline --param name=value` or SET VARIABLE sets them.

-- Position noise per camera: measured by sql/stages/calibrate.sql (calib_cameras.sigma_m).
CREATE OR REPLACE TEMP TABLE view_points AS
SELECT camera, class, q.x, q.y
FROM (SELECT p.camera, p.class, transform_point(f.to_reference, p.x, p.y) AS q
      FROM points p JOIN align_frames f USING (camera)
      WHERE p.estimated = 0);

-- A class is seen at least wherever a smaller class is seen (a bus is detected where a person
-- is): a class's view is the union of its own hull and the hulls of the classes no longer than
-- it (class_length_m). Why: a class's own hull is only as good as its sample. Three buses drew a
-- heavy-vehicle view of camera 2 that a fourth bus on another route left, so its 13 s in two
-- cameras were never compared, and it counted as two road users (issue 38's grid, --viewpoint-bias
-- 0.5,0.1: 1 of 3 heavy vehicles split). Smaller classes keep their own smaller views (a person
-- far from the camera is not detected where a car still is).
CREATE OR REPLACE TEMP TABLE view_polygons AS
WITH own AS (
    SELECT h.camera, h.class,
           polygon_buffer(h.hull, -getvariable('overlap_shrink_sigmas') * coalesce(n.sigma_m, 0)) AS polygon, h.n_points
    FROM (
        SELECT camera, coalesce(class, '*') AS class,
               view_polygon(list({'x': x, 'y': y}), getvariable('overlap_method'), getvariable('overlap_concavity'),
                            getvariable('overlap_radius_m'), getvariable('overlap_min_neighbours')) AS hull,
               count(*) AS n_points
        FROM view_points
        GROUP BY GROUPING SETS ((camera, class), (camera))
    ) h LEFT JOIN calib_cameras n USING (camera)
)
,
-- one union per camera and class length (a handful), not per class: a label per track (10,000
-- classes) would otherwise union every class with every other
tier AS (
    SELECT camera, class_length_m(class) AS length_m, list(polygon ORDER BY class) AS polys
    FROM own WHERE class <> '*' AND polygon IS NOT NULL GROUP BY ALL
),
upto AS (
    SELECT a.camera, a.length_m, flatten(list(b.polys ORDER BY b.length_m)) AS polys
    FROM tier a JOIN tier b ON b.camera = a.camera AND b.length_m <= a.length_m GROUP BY ALL
),
cum AS (SELECT camera, length_m, CASE WHEN len(polys) = 1 THEN polys[1] ELSE polygon_union(polys) END AS polygon FROM upto)
SELECT *, polygon_area(polygon) AS area_m2 FROM (
SELECT o.camera, o.class, CASE WHEN o.class = '*' THEN o.polygon ELSE c.polygon END AS polygon, o.n_points
FROM own o LEFT JOIN cum c ON c.camera = o.camera AND c.length_m = class_length_m(o.class));
-- view_points (every real point in the reference frame) has served: dropped, not kept for the
-- rest of the run (100 MB of a day's peak memory). IF EXISTS: a window run never makes it.
-- Qualified temp.main: an unqualified name would reach a table of the user's own of that name
-- when the temporary one is absent.
DROP TABLE IF EXISTS temp.main.view_points;

CREATE OR REPLACE TEMP TABLE view_overlaps AS
SELECT *, polygon_area(polygon) AS area_m2 FROM (
SELECT a.class, a.camera AS cam_a, b.camera AS cam_b, polygon_overlap(a.polygon, b.polygon) AS polygon
FROM view_polygons a JOIN view_polygons b ON a.class = b.class AND a.camera < b.camera);

-- The merge order Ω (thesis Alg. 3/4): position -> camera. Replace to merge in another order.
CREATE OR REPLACE TEMP TABLE view_merge_order AS
SELECT row_number() OVER (ORDER BY o.data_rank, v.camera) AS position, v.camera
FROM (SELECT DISTINCT camera FROM view_polygons) v LEFT JOIN calib_camera_order o USING (camera);

CREATE OR REPLACE TEMP TABLE view_overlaps_chain AS
SELECT *, polygon_area(polygon) AS area_m2 FROM (
SELECT nxt.class,
       list(prev.camera ORDER BY po.position) AS merged,
       nxt.camera,
       polygon_overlap(polygon_union(list(prev.polygon)), any_value(nxt.polygon)) AS polygon
FROM view_polygons nxt
JOIN view_merge_order no ON no.camera = nxt.camera
JOIN view_merge_order po ON po.position < no.position
JOIN view_polygons prev ON prev.camera = po.camera AND prev.class = nxt.class
GROUP BY nxt.class, nxt.camera);

SELECT class, cam_a, cam_b, round(area_m2, 1) AS overlap_m2,
       round(area_m2 / least((SELECT area_m2 FROM view_polygons v WHERE v.camera = cam_a AND v.class = o.class),
                             (SELECT area_m2 FROM view_polygons v WHERE v.camera = cam_b AND v.class = o.class)), 3) AS share_of_smaller
FROM view_overlaps o
ORDER BY class, cam_a, cam_b;
