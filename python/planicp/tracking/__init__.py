"""Tracking: keeping the robot's pose in the plan scan by scan, and finding it again.

`localize` aligns one scan to the plan with ICP (`IcpConfig` in, `IcpResult` out); `Localizer`
(`localizer`) tracks the robot from scans and odometry, judging each fit with its rules, one module
each: `AcceptanceGate` (`acceptance_gate`), `MotionNoise` (`motion_noise`), `OcclusionRule`
(`occlusion_rule`), `FusionRule` (`fusion_rule`), `DegeneracyRule` (`degeneracy_rule`),
`ContinuityRule` (`continuity_rule`) and `LostRule` (`lost_rule`), and refines each corrected pose
to the scan's most likely one in the plan's likelihood field (`posterior_refinement`:
`PosteriorRefinement`); when it is lost, `Recovery`
(`recovery`) finds it again with the global search of `relocalize`. A plan whose scale is off is
noticed while tracking (`scale_check`: `ScaleRule`, `ScaleEstimate`, on the per-scan evidence of
`scale_evidence`) and measured from the first scans (`scale_estimation`: `estimate_scale`). The
public names are exported by `planicp` itself; import them from there.
"""
