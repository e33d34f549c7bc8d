-- trajdb: what a finished pipeline run found, in a few lines (`trajdb pipeline` prints them on
-- stderr after the stage times), in table pipeline_summary (k, line), ORDER BY k. Run after the
-- pipeline, on its connection: it reads the run's tables.
-- reads: merged, points, align_frames, merge_links, merge_groups, merge_chains   makes: pipeline_summary
CREATE OR REPLACE TEMP TABLE pipeline_summary AS
WITH n AS (SELECT (SELECT count(*) FROM merged) AS users, (SELECT count(*) FROM merged WHERE n_tracks > 1) AS multi,
                  (SELECT count(DISTINCT camera) FROM points) AS cams, (SELECT count(*) FROM align_frames) AS aligned,
                  (SELECT coalesce(string_agg(class || ' ' || n, ', ' ORDER BY n DESC, class), '')
                   FROM (SELECT class, count(*) AS n FROM merged GROUP BY class)) AS per_class,
                  -- cross-camera links: accepted pairs whose two tracks ended in one road user (a 'reach' link joins
                  -- pieces of one camera's chain, not two cameras)
                  (SELECT count(*) FROM merge_links m JOIN merge_groups a ON a.uid = m.uid_a JOIN merge_groups b ON b.uid = m.uid_b
                   WHERE a.road_user = b.road_user AND m.kind <> 'reach') AS links,
                  (SELECT count(*) FROM merge_chains WHERE track_id <> linked_id) AS chains)
SELECT 1 AS k, format('found    {} road users ({}); {} seen by more than one track', users, per_class, multi) AS line FROM n
UNION ALL
SELECT 2, format('         {} of {} cameras in one frame; {} cross-camera links; {} tracks joined to an earlier piece in their camera',
                 aligned, cams, links, chains) FROM n;
