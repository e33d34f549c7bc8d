-- trajdb: what one window of a partitioned run keeps, and whether its halo was wide enough
-- (python/trajdb/windows.py runs it after the stages; trajdb.spark runs that per (site, window)).
--
-- A window [window_start, window_end) on the reference clock is run on every COMPLETE track
-- that touches [loaded_from, loaded_to] (the window and its halo). It keeps the road users
-- whose first real observation lies in the window, so every road user is kept by exactly one
-- window, however many windows its tracks reach into.
--
-- Why the result equals a run on the whole site: every decision about a road user (the LCSS
-- scores, Hungarian per camera pair, merge_groups, the within-camera links of quality.sql)
-- depends only on the tracks of its COMPONENT: tracks joined by a scored pair at or above
-- merge_eta, a kept link, or a quality event (a candidate end -> start). Candidates lie within
-- reach = max(merge_time_window, quality_max_gap) seconds of each other in time. So if every
-- track of the component lies within [loaded_from + reach, loaded_to - reach], no track the
-- window did not load can be a candidate of it, and the component is the same as in the whole
-- site. Otherwise window_status says how wide the halo must be, and the runner runs the window
-- again with that halo (python/trajdb/spark.py), until every kept component is complete.
--
-- Input: the pipeline's tables; variables window_start, window_end, loaded_from, loaded_to.
-- Output:
--   window_components(uid, component)
--   window_road_users(road_user, key, first_seen, keep)   key: 'camera:track_id' of its first
--                                                          source, unique in the site
--   window_status(kept, halo_before_s, halo_after_s, complete)  the halo each side needs

CREATE OR REPLACE TEMP TABLE window_edges AS
SELECT uid_a AS a, uid_b AS b FROM merge_scores WHERE eta >= getvariable('merge_eta')
UNION
SELECT uid_a, uid_b FROM merge_links
UNION
SELECT ta.uid, tb.uid
FROM quality_events e
JOIN quality_links la ON la.camera = e.camera AND la.track_id = e.ev.from_id
JOIN quality_links lb ON lb.camera = e.camera AND lb.track_id = e.ev.to_id
JOIN merge_tracks ta ON ta.camera = la.camera AND ta.track_id = la.linked_id
JOIN merge_tracks tb ON tb.camera = lb.camera AND tb.track_id = lb.linked_id
WHERE ta.uid <> tb.uid;

-- connected components: merge_groups with every track its own camera refuses no link
CREATE OR REPLACE TEMP TABLE window_components AS
SELECT g.id AS uid, g.grp AS component
FROM (SELECT unnest(merge_groups(
          (SELECT coalesce(list({'id': uid, 'camera': uid, 't0': t0, 't1': t1}), []) FROM merge_tracks),
          (SELECT coalesce(list({'a': a, 'b': b} ORDER BY a, b), []) FROM window_edges))) AS g);

CREATE OR REPLACE TEMP TABLE window_road_users AS
WITH ru AS (
    SELECT g.road_user, min(t.t0) AS first_seen, any_value(c.component) AS component
    FROM merge_groups g JOIN merge_tracks t USING (uid) JOIN window_components c USING (uid)
    GROUP BY g.road_user
)
SELECT ru.road_user, r.sources[1].camera || ':' || r.sources[1].track_id AS key, ru.first_seen, ru.component,
       ru.first_seen >= getvariable('window_start') AND ru.first_seen < getvariable('window_end') AS keep
FROM ru JOIN result_road_users() r USING (road_user);

CREATE OR REPLACE TEMP TABLE window_status AS
WITH span AS (
    SELECT c.component, min(t.t0) AS c0, max(t.t1) AS c1
    FROM window_components c JOIN merge_tracks t USING (uid)
    WHERE c.component IN (SELECT component FROM window_road_users WHERE keep)
    GROUP BY c.component
),
need AS (
    SELECT greatest(getvariable('merge_time_window'), getvariable('quality_max_gap')) AS reach,
           (SELECT count(*) FROM window_road_users WHERE keep) AS kept,
           (SELECT min(c0) FROM span) AS c0, (SELECT max(c1) FROM span) AS c1
)
SELECT kept,
       greatest(getvariable('window_start') - (c0 - reach), 0.0) AS halo_before_s,
       greatest((c1 + reach) - getvariable('window_end'), 0.0) AS halo_after_s,
       kept = 0 OR (c0 - reach >= getvariable('loaded_from') AND c1 + reach <= getvariable('loaded_to')) AS complete
FROM need;
