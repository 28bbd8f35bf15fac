"""Plant one-line bugs in the algorithm, one at a time, and check a test catches each.

    python scripts/plant_bugs.py            # every bug
    python scripts/plant_bugs.py sigma ...  # the named ones

Each bug replaces one exact piece of source (it must occur once), runs the tests named for it
with this checkout on PYTHONPATH, and restores the file whatever happens. A bug whose tests
all pass is reported MISSED (one that breaks the import, BROKEN); either makes the exit
status 1. `pytest -m slow tests/test_planted_bugs.py` runs the same list. The table in
docs/testing.md is this list; keep them together.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import NamedTuple

ROOT = Path(__file__).resolve().parents[1]
STEPS = "tests/learner/test_algorithm_steps.py"
TRIP = "tests/learner/test_state_round_trip.py"
MIGRATIONS = "tests/store/test_store_migrations.py"
PAPER = "tests/learner/test_paper_interest.py"
ALG2 = "tests/learner/test_paper_adaptation.py"
REFUSALS = "tests/learner/test_p_a_refusals.py"
NB = "tests/learner/test_neighbourhoods.py"
NAV = "tests/learner/test_navigation.py"
PL = "tests/learner/test_planner.py"


class Bug(NamedTuple):
    name: str
    path: str
    old: str
    new: str
    tests: str
    """pytest node ids (space-separated) that must fail."""


BUGS = (
    Bug("push-step-unbounded", "hadim_cli/learner/planner.py",
        "delta = gap if dist <= step else gap * (step / dist)", "delta = gap",
        "tests/learner/test_line_pushing.py"),
    Bug("navigator-heading-ignored", "hadim_cli/learner/navigation.py",
        "best = direct + line_angle(arrive, want) / turn", "best = direct",
        "tests/learner/test_pose_reaching.py"),
    Bug("hold-relation-from-here", "hadim_cli/learner/planner.py",
        "way = goal - offset_now - position",
        "way = self.value(aff.output, obs, b) - offset_now - position",
        "tests/learner/test_planner.py::test_an_object_input_heads_for_where_it_must_be_when_"
        "the_output_is_at_its_goal"),
    Bug("robust-fit-not-configured", "hadim_cli/learner/affordance.py",
        '"robust_iterations": self.config.robust_fit,', '"robust_iterations": 0,',
        "tests/learner/test_tool_rows.py::test_the_learner_config_sets_the_robustness_of_"
        "every_new_model"),
    Bug("robust-fit-no-reweighting", "hadim_cli/learner/models.py",
        "u = np.minimum(res / (ROBUST_CUTOFF * s), 1.0)", "u = np.zeros_like(res)",
        "tests/learner/test_models.py::test_robust_fits_ignore_a_few_blocked_rows"),
    Bug("robust-floor-over-the-batch", "hadim_cli/learner/models.py",
        "np.sqrt(np.mean(np.square(y_nb), axis=(1, 2))), 1e-12)[:, None]",
        "np.sqrt(np.mean(np.square(y_nb))), 1e-12)",
        "tests/learner/test_models.py::test_a_robust_fit_does_not_depend_on_the_other_queries_"
        "of_its_batch"),
    Bug("buffer-tie-at-the-edge-ignored", "hadim_cli/learner/models.py",
        "redo = np.flatnonzero(tie < used)", "redo = np.flatnonzero(tie + 1 < used)",
        "tests/learner/test_models_search.py::test_models_answer_alike_with_and_without_"
        "buffer_trees"),
    Bug("turn-units-not-extended", "hadim_cli/learner/frames.py",
        "        if have < self.n:", "        if have == 0:",
        "tests/learner/test_frames.py::test_the_kept_norms_and_directions_follow_the_rows_"
        "added"),
    Bug("turn-near-null-not-measured", "hadim_cli/learner/frames.py",
        "_NEAR = 1e-9\n", "_NEAR = 0.0\n",
        "tests/learner/test_frames.py::test_outcomes_at_the_null_threshold_are_measured_"
        "turned"),
    Bug("damaged-schema-read-as-foreign", "store/engine.py",
        'if getattr(exc.orig, "sqlite_errorcode", None) == sqlite3.SQLITE_CORRUPT:',
        'if getattr(exc.orig, "sqlite_errorcode", None) == -1:',
        "tests/test_first_day.py::test_a_store_damaged_where_its_schema_is_read_is_refused_as_"
        "damaged"),
    Bug("store-check-stops-at-damaged-schema", "hadim_cli/commands/store_cmd.py",
        "except DamagedStore:  # damaged where the schema is read",
        "except ValueError:  # damaged where the schema is read",
        "tests/test_first_day.py::test_a_store_damaged_where_its_schema_is_read_is_refused_as_"
        "damaged"),
    Bug("finish-trips-ignored", "hadim_cli/learner/planner.py",
        "going_on = self.pc.finish_trips and aff.id in self._placed_for",
        "going_on = self.pc.finish_trips and False",
        "tests/learner/test_planner.py::test_a_trip_under_way_goes_on_until_it_arrives"),
    Bug("finish-trips-not-recorded", "hadim_cli/learner/planner.py",
        "self._placed_for = frozenset(p.places for p in self.stack if p.places >= 0)",
        "self._placed_for = frozenset()",
        "tests/learner/test_planner.py::test_the_actions_of_a_trip_say_whose_trip_it_is"),
    Bug("pursue-line-final-place", "hadim_cli/learner/planner.py",
        "way = behind + u * (min(along, 0.0) + step) - position",
        "way = goal - offset_now - position",
        "tests/learner/test_planner.py::test_an_object_input_off_its_line_pursues_a_point_one_"
        "step_ahead_on_it"),
    Bug("pose-places-heading-kept", "hadim_cli/learner/planner.py",
        "return np.array([self.pc.pose_places and space == ROBOT_HEADING",
        "return np.array([False and space == ROBOT_HEADING",
        "tests/learner/test_planner.py::test_an_action_pusher_is_placed_with_the_heading_its_"
        "pushes_were_made_facing"),
    Bug("pose-places-not-driven", "hadim_cli/learner/planner.py",
        "heading if facing is None else facing)",
        "None if facing is None else facing)",
        "tests/learner/test_planner.py::test_the_place_of_an_action_pusher_is_driven_to_facing_"
        "its_heading"),
    Bug("untried-interest-ignored", "hadim_cli/learner/explorer.py",
        "if self.config.untried_interest:", "if False:",
        STEPS + "::test_an_affordance_tried_on_few_goals_is_practised_with_untried_interest"),
    Bug("untried-interest-forever", "hadim_cli/learner/explorer.py",
        "if a.interest.n_goals < self.config.interest_window else i",
        "if a.interest.n_goals >= 0 else i",
        STEPS + "::test_an_affordance_tried_on_few_goals_is_practised_with_untried_interest"),
    Bug("relations-seen-unused", "hadim_cli/learner/planner.py",
        "if self.pc.relations_seen:", "if False:",
        "tests/learner/test_planner.py::test_the_needed_context_checks_its_relation_against_"
        "the_rows_when_asked"),
    Bug("relations-seen-no-spread", "hadim_cli/learner/planner.py",
        "if np.linalg.norm(needed[sl]) < lengths.min() - lengths.std():",
        "if np.linalg.norm(needed[sl]) < lengths.min():",
        "tests/learner/test_planner.py::test_a_needed_relation_inside_the_object_gives_way_"
        "to_the_rows_own"),
    Bug("closer-places-unused", "hadim_cli/learner/planner.py",
        "off = self._gap(aff, spreads, c, near, relations)",
        "off = self._gap(aff, spreads, c, needed, relations)",
        "tests/learner/test_planner.py::test_a_pusher_nearer_on_the_needed_bearing_stands_at_"
        "its_place"),
    Bug("closer-places-any-length", "hadim_cli/learner/planner.py",
        "if relations[i] and now < float(np.linalg.norm(needed[sl])):",
        "if relations[i]:",
        "tests/learner/test_planner.py::test_a_pusher_nearer_on_the_needed_bearing_stands_at_"
        "its_place"),
    Bug("contact-places-unused", "hadim_cli/learner/planner.py",
        "used = self._reach_context(aff, b, self._at_contact(aff, needed, relations),\n"
        "                                       actuator, budget, depth, then=then)",
        "used = self._reach_context(aff, b, needed,\n"
        "                                       actuator, budget, depth, then=then)",
        "tests/learner/test_planner.py::test_a_trip_drives_to_contact_on_the_needed_bearing"),
    Bug("contact-places-no-margin", "hadim_cli/learner/planner.py",
        "out[sl] = _at_length(needed[sl], offset + CONTACT_MARGIN)",
        "out[sl] = _at_length(needed[sl], offset)",
        "tests/learner/test_planner.py::test_a_trip_drives_to_contact_on_the_needed_bearing"),
    Bug("body-frame-not-configured", "hadim_cli/learner/affordance.py",
        "body=self.config.body_frame", "body=False",
        "tests/learner/test_frames.py::test_the_learner_config_frames_the_robot_s_motion_"
        "models"),
    Bug("body-frame-output-not-turned", "hadim_cli/learner/frames.py",
        "axis = heading[0]",
        "axis = heading[0]; out = ACTION",
        "tests/learner/test_frames.py::test_the_robot_s_own_motion_is_framed_by_its_heading_"
        "only_when_asked"),
    Bug("free-motion-not-configured", "hadim_cli/learner/affordance.py",
        "if inp is ACTION and out.role is Role.ROBOT and self.config.free_motion:",
        "if inp is ACTION and out.role is Role.ROBOT:",
        "tests/learner/test_tool_rows.py::test_the_robots_motion_is_learned_from_moves_clear_"
        "of_everything"),
    Bug("free-motion-before-only", "hadim_cli/learner/affordance.py",
        "clear = (before.min(axis=1) > reach) & (after.min(axis=1) > reach)",
        "clear = before.min(axis=1) > reach",
        "tests/learner/test_tool_rows.py::test_the_robots_motion_is_learned_from_moves_clear_"
        "of_everything"),
    Bug("free-motion-objects-ignored", "hadim_cli/learner/affordance.py",
        "return clear & ~touched.any(axis=1)", "return clear",
        "tests/learner/test_tool_rows.py::test_the_robots_motion_is_learned_from_moves_clear_"
        "of_everything"),
    Bug("held-out-errors-in-sample", "hadim_cli/learner/competence.py",
        "e = np.linalg.norm(model.predict_loo() - y, axis=1)",
        "e = np.linalg.norm(model.predict(*model.data()[:2]) - y, axis=1)",
        "tests/learner/test_competence.py::test_held_out_errors_leave_each_row_out_of_its_own_"
        "fit"),
    Bug("pursuits-only-when-recording", "hadim_cli/evaluation/runner.py",
        "learner.planner, record)", "learner.planner if record else None, record)",
        "tests/test_eval_diagnostics.py::test_points_count_their_actions_by_what_the_planner_"
        "pursued"),
    Bug("scripted-no-steering", "hadim_cli/evaluation/scripted.py",
        "STEERING = True", "STEERING = False",
        "tests/test_scripted_controller.py::test_the_tool_pushes_the_target_off_its_start"
        "_line_without_the_robot_touching_it"),
    Bug("competence-in-sample", "hadim_cli/learner/competence.py",
        "model.predict_loo(rows)", "model.predict(model.data()[0][rows], model.data()[1][rows])",
        f"{STEPS}::test_competence_is_scored_on_held_out_rows"),
    Bug("backoff-not-restored", "hadim_cli/learner/state.py",
        "    learner.adaptation.backoff.wait = {k: int(v) for k, v in meta[\"backoff\"]"
        "[\"wait\"].items()}", "", TRIP),
    Bug("split-not-restored", "hadim_cli/learner/interest.py",
        "_Leaf(next_split_at=int(a[\"node_next_split_at\"][i]))", "_Leaf()", TRIP),
    Bug("contact-ignored", "hadim_cli/evaluation/runner.py",
        "error = 1.0 if actuator.touched else point_error(start, final, point)",
        "error = point_error(start, final, point)",
        "tests/test_evaluation.py::test_a_tool_task_fails_every_point_the_robot_touches_the"
        "_target_in"),
    Bug("contact-not-watched", "hadim_cli/evaluation/runner.py",
        "task.target if task.tool else None", "None",
        "tests/test_evaluation.py::test_a_tool_task_fails_every_point_the_robot_touches_the"
        "_target_in"),
    Bug("sigma-ignored", "hadim_cli/learner/explorer.py",
        "rng.random() < self.config.sigma", "rng.random() < 0.0",
        f"{STEPS}::test_sigma_is_the_share_of_goal_babbling"),
    Bug("deletion-never", "hadim_cli/learner/adaptation.py",
        "        self._delete_false(iteration)\n", "",
        f"{STEPS}::test_a_false_affordance_is_deleted_after_its_patience"),
    Bug("deletion-ignores-needed", "hadim_cli/learner/adaptation.py",
        " and self.h.deletable(aff)", "",
        f"{STEPS}::test_a_good_update_resets_the_low_streak_and_a_needed_affordance_stays"),
    Bug("low-streak-never-reset", "hadim_cli/learner/adaptation.py",
        "aff.low_streak + 1 if low else 0", "aff.low_streak + 1",
        f"{STEPS}::test_a_good_update_resets_the_low_streak_and_a_needed_affordance_stays"),
    Bug("match-always", "hadim_cli/learner/adaptation.py",
        "matched = aff.competence >= before - self.config.match_tolerance", "matched = True",
        f"{STEPS}::test_rows_that_do_not_match_trigger_a_context_search"),
    Bug("match-never", "hadim_cli/learner/adaptation.py",
        "matched = aff.competence >= before - self.config.match_tolerance", "matched = False",
        f"{STEPS}::test_rows_that_do_not_match_trigger_a_context_search"),
    Bug("review-never", "hadim_cli/learner/adaptation.py",
        "if not matched or review:", "if not matched:",
        f"{STEPS}::test_contexts_are_reviewed_every_few_updates_even_when_rows_match"),
    Bug("rows-not-absorbed", "hadim_cli/learner/adaptation.py",
        "        aff.rows = aff.rows.concat(rows)\n", "",
        f"{STEPS}::test_rows_that_do_not_match_trigger_a_context_search"),
    Bug("context-add-never", "hadim_cli/learner/adaptation.py",
        "            options.append((EventKind.CONTEXT_ADDED, (*current, c), {\"added\": c.name}))",
        "            pass",
        f"{STEPS}::test_a_context_change_reaches_the_context_the_data_need"),
    Bug("context-replace-never", "hadim_cli/learner/adaptation.py",
        "                options.append((EventKind.CONTEXT_REPLACED, (*rest, c),",
        "                0 and options.append((EventKind.CONTEXT_REPLACED, (*rest, c),",
        f"{STEPS}::test_a_context_change_reaches_the_context_the_data_need"),
    Bug("context-remove-never", "hadim_cli/learner/adaptation.py",
        "            options.append((EventKind.CONTEXT_REMOVED, rest, {\"removed\": old.name}))",
        "            pass",
        f"{STEPS}::test_a_context_change_reaches_the_context_the_data_need"),
    Bug("context-gain-ignored", "hadim_cli/learner/adaptation.py",
        "required_gain(len(aff.contexts), len(contexts), cfg.context_gain)",
        "required_gain(len(aff.contexts), len(contexts), 0.0)",
        f"{STEPS}::test_the_right_context_is_kept "
        f"{STEPS}::test_a_context_that_does_not_earn_its_gain_is_not_added"),
    Bug("tau-modification-ignored", "hadim_cli/learner/adaptation.py",
        "if value < cfg.tau_modification:", "if False:",
        f"{STEPS}::test_a_context_that_does_not_earn_its_gain_is_not_added"),
    Bug("context-not-refitted", "hadim_cli/learner/adaptation.py",
        "        aff.model = f.fit(aff.input, aff.output, aff.contexts, aff.rows)\n", "",
        f"{STEPS}::test_a_context_change_reaches_the_context_the_data_need"),
    Bug("creation-never", "hadim_cli/learner/adaptation.py",
        "            self._try_create(space, iteration, episode, rng)\n", "",
        f"{STEPS}::test_creation_finds_the_drive_and_its_context"),
    Bug("tau-creation-ignored", "hadim_cli/learner/adaptation.py",
        "            if value < self.config.tau_creation:\n", "            if False:\n",
        f"{STEPS}::test_nothing_is_created_from_noise_and_the_trial_backs_off"),
    Bug("creation-context-never", "hadim_cli/learner/adaptation.py",
        "options = [(bare, ())] + [", "options = [(bare, ())] or [",
        f"{STEPS}::test_creation_finds_the_drive_and_its_context"),
    Bug("backoff-ignored", "hadim_cli/learner/adaptation.py",
        "            if not self.backoff.ready(inp, out, episode):\n                continue\n",
        "", f"{STEPS}::test_nothing_is_created_from_noise_and_the_trial_backs_off"),
    Bug("backoff-not-doubled", "hadim_cli/learner/adaptation.py",
        "wait = min(16, 2 * self.wait.get(key, 1))", "wait = 2",
        f"{STEPS}::test_back_off_doubles_up_to_sixteen_episodes"),
    Bug("duplicate-creation", "hadim_cli/learner/hierarchy.py",
        "return [s for s in out if s not in existing]", "return out",
        f"{STEPS}::test_an_input_already_used_for_an_output_is_not_created_again"),
    Bug("p-a-labels-inverted", "hadim_cli/learner/adaptation.py",
        "labels = moved[pick]", "labels = ~moved[pick]",
        f"{STEPS}::test_p_a_is_taught_movers_as_positives_the_robot_and_in_vain_pushes_as_"
        "negatives"),
    Bug("p-a-robot-positive", "hadim_cli/learner/adaptation.py",
        "labels = np.concatenate([labels, [False]])", "labels = np.concatenate([labels, [True]])",
        f"{STEPS}::test_p_a_is_taught_movers_as_positives_the_robot_and_in_vain_pushes_as_"
        "negatives"),
    Bug("p-a-no-negatives", "hadim_cli/learner/adaptation.py",
        "pick = moved | negative", "pick = moved",
        f"{STEPS}::test_p_a_is_taught_movers_as_positives_the_robot_and_in_vain_pushes_as_"
        "negatives"),
    Bug("affordance-selection-uniform", "hadim_cli/learner/explorer.py",
        "select_index(interests, rng, self.config.interest_epsilon)",
        "select_index(interests, rng, 1.0)",
        f"{STEPS}::test_goal_babbling_picks_affordances_by_interest_and_records_the_attempt"),
    Bug("interest-not-updated", "hadim_cli/learner/explorer.py",
        "            aff.interest.add(goal, attempt.competence, self.iteration)\n",
        "            pass\n",
        f"{STEPS}::test_goal_babbling_picks_affordances_by_interest_and_records_the_attempt"),
    Bug("paper-interest-not-configured", "hadim_cli/learner/affordance.py",
        "measure = Progress.PAPER if cfg.paper_interest else Progress.HALF_WINDOW",
        "measure = Progress.HALF_WINDOW",
        f"{PAPER}::test_a_paper_map_records_each_outcome_reached_with_the_forward_models_error"),
    Bug("paper-interest-not-updated", "hadim_cli/learner/explorer.py",
        "                self.update_interest_maps(np.arange(start, stop, dtype=np.int64))\n",
        "                pass\n",
        f"{PAPER}::test_every_learning_episode_updates_the_paper_maps_before_adaptation"),
    Bug("paper-interest-goal-attempts-too", "hadim_cli/learner/explorer.py",
        "        if not self.config.paper_interest:", "        if True:",
        f"{PAPER}::test_every_learning_episode_updates_the_paper_maps_before_adaptation"),
    Bug("paper-interest-at-start", "hadim_cli/learner/affordance.py",
        "return ((before + s.y)[order]", "return (before[order]",
        f"{PAPER}::test_a_paper_map_records_each_outcome_reached_with_the_forward_models_error"),
    Bug("paper-progress-unsigned", "hadim_cli/learner/interest.py",
        "return float(abs(np.diff(competence)[-n:].mean()))",
        "return float(np.abs(np.diff(competence)[-n:]).mean())",
        "tests/learner/test_interest.py::test_paper_progress"),
    Bug("paper-competence-not-last-k", "hadim_cli/learner/interest.py",
        "begin = np.maximum(0, end - k)", "begin = np.zeros_like(end)",
        "tests/learner/test_interest.py::test_paper_progress"),
    Bug("region-selection-uniform", "hadim_cli/learner/interest.py",
        "k = select_index(self._interests(), rng, 0.0)",
        "k = select_index(self._interests(), rng, 1.0)",
        "tests/learner/test_interest.py::test_sampling_prefers_high_interest_region"),
    Bug("no-fallback", "hadim_cli/learner/explorer.py",
        "            return self._random_controllable(actuator, rng).after(Fallback.GOAL_NO_PLAN)",
        "            pass",
        f"{STEPS}::test_a_goal_attempt_that_cannot_be_planned_falls_back_to_random_babbling"),
    Bug("object-selection-ignores-p-a", "hadim_cli/learner/explorer.py",
        "return objects[aff.classifier.accepts(features)]", "return objects",
        f"{STEPS}::test_object_selection_takes_the_closest_object_p_a_accepts"),
    Bug("p-a-blocked-not-taught", "hadim_cli/learner/adaptation.py",
        "        if blocked is not None and len(blocked):\n            rows = rows.concat(",
        "        if False:\n            rows = rows.concat(",
        f"{STEPS}::test_an_object_that_stops_the_robot_teaches_p_a_with_blocked_pushes"),
    Bug("p-a-blocked-only-when-updated", "hadim_cli/learner/adaptation.py",
        "                if aff.output not in spaces:\n", "                if False:\n",
        f"{STEPS}::test_a_blocked_push_in_an_episode_where_nothing_moved_still_teaches_p_a"),
    Bug("p-a-not-pooled", "hadim_cli/learner/adaptation.py",
        "                self._teach_pooled(self.h.with_output(space), t, rng)",
        "                [self._teach_pooled([a], t, rng) for a in self.h.with_output(space)]",
        "tests/learner/test_p_a_pooled.py::test_pooled_p_a_is_right_on_the_scene_and_on_unseen"
        "_objects"),
    Bug("p-a-refusals-not-taught", "hadim_cli/learner/adaptation.py",
        "            refused = self._refused(t)\n", "            refused = Rows.empty()\n",
        f"{REFUSALS}::test_p_a_from_refusals_is_right_on_the_scene_and_on_unseen_objects"),
    Bug("p-a-refusal-graze", "hadim_cli/learner/adaptation.py",
        "(depth > 0.5 * step)", "(depth > -step)",
        f"{REFUSALS}::test_an_object_that_stops_the_robot_refused_it_a_graze_or_backing_away"
        "_did_not"),
    Bug("p-a-refusal-not-stopped", "hadim_cli/learner/adaptation.py",
        "& (went < 0.5 * step)", "& (went < np.inf)",
        f"{REFUSALS}::test_a_move_a_young_motion_model_misplaces_is_no_refusal"),
    Bug("p-a-refusals-only-when-moved", "hadim_cli/learner/adaptation.py",
        "        if self.config.p_a_refusals and OBJECT_POSITION not in adapted:",
        "        if False:",
        f"{REFUSALS}::test_refusals_teach_p_a_in_a_learning_episode_where_nothing_moved"),
    Bug("p-a-refusal-moved-before", "hadim_cli/learner/adaptation.py",
        "        still = ~np.isin(rows.target, np.unique(seen.target[changed]))\n"
        "        return rows.take(np.flatnonzero(still))\n\n    def _blocked",
        "        still = np.ones(len(rows), dtype=bool)\n"
        "        return rows.take(np.flatnonzero(still))\n\n    def _blocked",
        f"{REFUSALS}::test_an_object_that_moved_earlier_in_the_episode_is_no_refusal"),
    Bug("p-a-refusals-keep-model-negatives", "hadim_cli/learner/adaptation.py",
        "        if self.config.p_a_refusals and aff.output == OBJECT_POSITION:",
        "        if False:",
        f"{REFUSALS}::test_a_pushable_object_is_no_negative_even_where_the_pushing_model"
        "_expects_a_push"),
    Bug("open-contexts-ignored", "hadim_cli/learner/adaptation.py",
        "every = context_candidates(roles, open_all=self.config.open_contexts)",
        "every = context_candidates(roles)",
        "tests/learner/test_open_spaces.py::test_the_context_search_tries_the_open_spaces_when"
        "_asked"),
    Bug("open-outputs-ignored", "hadim_cli/learner/adaptation.py",
        "outputs = OPEN_OUTPUT_SPACES if self.config.open_outputs else OUTPUT_SPACES",
        "outputs = OUTPUT_SPACES",
        "tests/learner/test_open_spaces.py::test_the_lidar_is_an_output_only_when_outputs_are"
        "_open"),
    Bug("mismatch-absorbed-anyway", "hadim_cli/learner/adaptation.py",
        "        if not self.config.absorb_mismatch \\\n",
        "        if False \\\n",
        f"{STEPS}::test_rows_that_no_context_makes_fit_are_given_back_without_absorb_mismatch"),
    Bug("paper-picks-each-once", "hadim_cli/learner/adaptation.py",
        "        if self.config.paper_picks:\n            drawn = rng.integers(",
        "        if False:\n            drawn = rng.integers(",
        f"{ALG2}::test_paper_picks_draw_k_spaces_with_replacement_and_the_default_each_once"),
    Bug("paper-picks-adapted-twice", "hadim_cli/learner/adaptation.py",
        "                continue  # (paper picks) drawn again", "                pass  #",
        f"{ALG2}::test_a_space_picked_twice_is_adapted_once"),
    Bug("paper-match-same-output-only", "hadim_cli/learner/adaptation.py",
        "if self.config.paper_matching and self._explained_elsewhere(space, t, iteration,",
        "if False and self._explained_elsewhere(space, t, iteration,",
        f"{ALG2}::test_a_match_with_another_output_stands_for_creation"),
    Bug("paper-match-any-property", "hadim_cli/learner/adaptation.py",
        "if borrowed_space(out) != space or aff.model.n < 3:", "if aff.model.n < 3:",
        f"{ALG2}::test_data_of_another_output_match_an_affordance_that_explains_them"),
    Bug("paper-adds-read-as-own", "hadim_cli/learner/affordance.py",
        "if rows.borrowed is not None and rows.borrowed.any():",
        "if False:",
        f"{ALG2}::test_a_borrowed_row_reads_the_other_outputs_outcome"),
    Bug("paper-adds-not-checkpointed", "hadim_cli/learner/state.py",
        "    if aff.rows.borrowed is not None:\n", "    if False:\n",
        f"{TRIP}::test_a_restored_learner_equals_the_saved_one_in_every_field"),
    Bug("paper-adds-nothing", "hadim_cli/learner/adaptation.py",
        "            self._take_in(aff, aff.contexts, rows, iteration, rng)\n"
        "            return True",
        "            return True",
        f"{ALG2}::test_with_adds_a_match_takes_the_other_outputs_data_in_as_borrowed_rows"),
    Bug("paper-adds-no-context-search", "hadim_cli/learner/adaptation.py",
        "        for _ in range(len(candidates)):", "        for _ in range(0):",
        f"{ALG2}::test_without_a_match_a_context_is_searched_k_prime_times"),
    Bug("paper-adds-ignored-switch", "hadim_cli/learner/adaptation.py",
        "        if not self.config.paper_match_adds:\n", "        if False:\n",
        f"{ALG2}::test_without_adds_a_match_adds_nothing"),
    Bug("paper-literal-config-incomplete", "configs/paper-literal.toml",
        "paper_match_adds = true\n", "",
        f"{ALG2}::test_the_paper_literal_config_turns_every_paper_switch_on_and_trains"),
    Bug("paper-adds-first-match-only", "hadim_cli/learner/adaptation.py",
        "matched |= self._borrow(", "matched = matched or self._borrow(",
        f"{ALG2}::test_with_adds_every_matching_affordance_takes_the_data_in"),
    Bug("paper-adds-without-matching", "hadim_cli/config.py",
        "_check(self.paper_matching or not self.paper_match_adds,", "_check(True,",
        f"{ALG2}::test_adds_need_paper_matching"),
    Bug("interest-state-by-leaf", "hadim_cli/learner/interest.py",
        'order = np.argsort(np.array(seq, dtype=np.int64), kind="stable")',
        "order = np.arange(len(seq))",
        "tests/test_long_sessions.py::test_a_learner_checkpoint_grows_only_at_its_end"),
    Bug("interest-sequence-not-restored", "hadim_cli/learner/interest.py",
        "            leaf.sequence.append(i)", "            pass",
        f"{TRIP}::test_a_restored_learner_equals_the_saved_one_in_every_field"),
    Bug("papers-rules-legacy-forgotten", "hadim_cli/config.py",
        '"p_a_refusals": False, "open_contexts": False, "absorb_mismatch": True,\n',
        '"p_a_refusals": False,\n',
        "tests/test_config.py::test_a_run_stored_before_the_papers_rules_were_the_default_keeps_"
        "its_own"),
    Bug("paper-match-parked-objects", "hadim_cli/learner/adaptation.py",
        "keep &= np.isin(sample.rows.target, seen.target[changed])", "keep &= True",
        f"{ALG2}::test_only_objects_that_moved_are_the_picked_space"),
    Bug("paper-match-always", "hadim_cli/learner/adaptation.py",
        "        return rows is not None and self._keeps_competence(aff, rows, rng)",
        "        return rows is not None",
        f"{ALG2}::test_data_of_another_output_match_an_affordance_that_explains_them"),
    Bug("learning-episodes-not-restored", "hadim_cli/learner/state.py",
        "    learner.learning_episodes = int(meta[\"learning_episodes\"])\n", "", TRIP),
    Bug("low-streak-not-restored", "hadim_cli/learner/state.py",
        "int(meta[\"low_streak\"]))", "0)", TRIP),
    # The store's migrations (tests/store/test_store_migrations.py).
    Bug("upgrade-cascades", "store/schema.py", 'raw.execute("PRAGMA foreign_keys = OFF")',
        "pass", f"{MIGRATIONS}::test_a_manual_revision_waits_for_upgrade_and_a_rebuild"
        "_cascades_nothing[file]"),
    Bug("upgrade-skips-fk-check", "store/schema.py", "        if orphans:", "        if False:",
        f"{MIGRATIONS}::test_rows_left_pointing_nowhere_refuse_the_upgrade_on_sqlite"),
    Bug("stamp-committed-alone", "store/schema.py", "        _stamp(conn, state.version)\n",
        "        _stamp(conn, state.version)\n        conn.commit()\n",
        f"{MIGRATIONS}::test_a_failed_upgrade_of_a_store_from_before_alembic_stamps_nothing"),
    Bug("manual-revision-on-open", "store/engine.py", "if manual and not explicit:",
        "if False:", f"{MIGRATIONS}::test_a_manual_revision_waits_for_upgrade_and_a_rebuild"
        "_cascades_nothing[file]"),
    Bug("revision-1-drifts", "store/migrations/versions/0001_schema_1.py",
        'sa.Column("task", sa.String(128), nullable=False)',
        'sa.Column("task", sa.String(128), nullable=True)',
        f"{MIGRATIONS}::test_revision_1_is_the_schema_of_a_store_written_by_schema_1"),
    Bug("settle-ignored", "hadim_cli/world/world.py", "        if self._settle:\n",
        "        if False:\n",
        "tests/world/test_world_physics.py::test_every_action_starts_from_standstill_whatever_"
        "came_before"),
    Bug("settle-legacy-forgotten", "hadim_cli/config.py", '    "world": {"settle_time": 0.0},\n',
        "", "tests/test_long_sessions.py::test_a_schema_1_store_opens_and_resumes_exactly "
        "tests/baselines/test_combinations.py::test_a_baseline_stored_before_a_world_key_"
        "existed_keeps_the_world_it_trained_in"),
    Bug("place-tolerance-ignored-in-cost", "hadim_cli/learner/navigation.py",
        "        direct = np.where(inside, apart / speed if self.config.precise_places else 0.0,"
        " direct)\n", "",
        "tests/learner/test_pose_reaching.py"),
    Bug("robot-only-counts-pushes", "hadim_cli/evaluation/runner.py",
        "- objects, axis=1)\n                                       < MOVED))",
        "- objects, axis=1)\n                                       < 1.0))",
        "tests/test_eval_diagnostics.py::test_an_action_counts_as_robot_only_unless_it_moves_"
        "an_object"),
    Bug("push-length-every-action", "hadim_cli/evaluation/runner.py",
        "            if moved >= MOVED:\n                self.driven_moves += 1",
        "            if True:\n                self.driven_moves += 1",
        "tests/test_eval_diagnostics.py::test_a_push_length_is_the_driven_object_s_travel_per_"
        "action_that_moved_it"),
    Bug("first-push-overwritten", "hadim_cli/evaluation/runner.py",
        "if self._pushed is not None and self.first_push is None:",
        "if self._pushed is not None:",
        "tests/test_eval_diagnostics.py::test_the_first_push_says_how_it_was_lined_up"),
    Bug("first-push-read-after", "hadim_cli/evaluation/runner.py",
        "robot_off = angle_between(pusher - at(before, 0), pushed - pusher)",
        "robot_off = angle_between(pusher - at(after, 0), pushed - pusher)",
        "tests/test_eval_diagnostics.py::test_the_first_push_through_a_tool_measures_the_"
        "chain_s_bend"),
    Bug("first-push-move-off-the-pusher", "hadim_cli/evaluation/runner.py",
        "angle_between(moved, way), robot_off)",
        "angle_between(moved, pushed - pusher), robot_off)",
        "tests/test_eval_diagnostics.py::test_the_first_push_says_how_it_was_lined_up"),
    Bug("trip-starts-from-the-end", "hadim_cli/evaluation/runner.py",
        "shares = tuple(remaining_share(learner.reader.entity_position(o, entity), start, point)",
        "shares = tuple(remaining_share(learner.reader.entity_position(actuator.obs, entity), "
        "start, point)",
        "tests/test_eval_diagnostics.py::test_trip_starts_are_the_goal_s_remaining_share_when_"
        "each_trip_began"),
    Bug("trip-starts-after-the-trip", "hadim_cli/learner/planner.py",
        "self._count_trip(starting, before)\n                return done",
        "self._count_trip(starting, actuator.obs)\n                return done",
        "tests/test_eval_diagnostics.py::test_trip_starts_are_the_goal_s_remaining_share_when_"
        "each_trip_began"),
    Bug("remaining-share-from-the-start", "hadim_cli/evaluation/metric.py",
        "return float(np.linalg.norm(np.subtract(target, position))) / max(initial, 1e-12)",
        "return float(np.linalg.norm(np.subtract(position, start))) / max(initial, 1e-12)",
        "tests/test_evaluation.py::test_the_remaining_share_is_the_error_so_far_unclipped"),
    Bug("kernels-not-pinned", "hadim_cli/numerics.py",
        "        os.environ.setdefault(key, value)",
        "        pass",
        "tests/test_numerics.py::test_importing_hadim_first_pins_every_library_to_avx2_kernels"),
    Bug("near-pursuit-ignored", "hadim_cli/learner/planner.py",
        "near if self.pc.near_pursuit\n", "needed if self.pc.near_pursuit\n",
        "tests/learner/test_planner.py::test_an_object_input_nearer_than_needed_pursues_its_"
        "line_from_where_it_stands"),
    Bug("precise-places-ignored", "hadim_cli/learner/navigation.py",
        "if self.config.precise_places else 0.0", "if False else 0.0",
        "tests/learner/test_navigation.py::test_a_place_within_its_tolerance_is_still_driven_"
        "to_as_near_as_the_grid_allows"),
    Bug("k-choice-always-the-first", "hadim_cli/learner/models.py",
        "self.k_fit = self.k_choices[int(np.argmin(errors))]",
        "self.k_fit = self.k_choices[0]",
        f"{NB}::test_the_neighbourhood_of_least_leave_one_out_error_is_chosen"),
    Bug("k-fit-unused", "hadim_cli/learner/models.py",
        "dist, nb = self._query(_FORWARD, z, min(self.k_fit, self._n))",
        "dist, nb = self._query(_FORWARD, z, min(self.k_forward, self._n))",
        f"{NB}::test_the_neighbourhood_of_least_leave_one_out_error_is_chosen"),
    Bug("k-choice-not-restored", "hadim_cli/learner/models.py",
        "self.k_fit, self._chosen_at = int(k[4]), int(k[5])", "pass",
        f"{NB}::test_the_chosen_neighbourhood_survives_a_state_round_trip"),
    Bug("k-choices-not-configured", "hadim_cli/learner/affordance.py",
        '"k_choices": () if trial else self.config.k_choices}', '"k_choices": ()}',
        f"{NB}::test_the_learner_config_reaches_the_models_and_old_runs_keep_none"),
    Bug("trial-chooses", "hadim_cli/learner/affordance.py",
        '"k_choices": () if trial else self.config.k_choices}',
        '"k_choices": self.config.k_choices}',
        f"{NB}::test_a_trial_model_keeps_k_forward"),
    Bug("trial-fit-as-a-model", "hadim_cli/learner/affordance.py",
        "self.fit(inp, out, contexts, rows, trial=True)", "self.fit(inp, out, contexts, rows)",
        f"{NB}::test_a_trial_model_keeps_k_forward"),
    Bug("k-choices-legacy-forgotten", "hadim_cli/config.py",
        '"absorb_mismatch": True,\n                "k_choices": (), "chain_objects": False,',
        '"absorb_mismatch": True, "chain_objects": False,',
        f"{NB}::test_the_learner_config_reaches_the_models_and_old_runs_keep_none"),
    Bug("chain-objects-ignored", "hadim_cli/learner/explorer.py",
        "if self.config.chain_objects:\n            return self._shortest_chain(",
        "if False:\n            return self._shortest_chain(",
        f"{STEPS}::test_object_selection_through_a_tool_takes_the_shortest_chain"),
    Bug("chain-objects-robot-way-forgotten", "hadim_cli/learner/explorer.py",
        "reach = float(np.linalg.norm(where[tool] - robot))", "reach = 0.0",
        f"{STEPS}::test_object_selection_through_a_tool_takes_the_shortest_chain"),
    Bug("chain-objects-legacy-forgotten", "hadim_cli/config.py",
        '"k_choices": (), "chain_objects": False,', '"k_choices": (),',
        "tests/test_config.py::"
        "test_a_run_stored_before_tools_were_chosen_by_their_chain_keeps_its_objects"),
    Bug("own-relations-ignored", "hadim_cli/learner/adaptation.py",
        "return config.context_gain if any(c.roles - own for c in contexts) else 0.0",
        "return 0.0",
        f"{STEPS}::test_a_tool_affordance_is_created_with_the_tools_relation_unless_the_robots"
        f"_earns_it {STEPS}::test_only_a_relation_to_an_entity_outside_the_affordance_is_held_"
        "back"),
    Bug("own-relations-actor-forgotten", "hadim_cli/learner/adaptation.py",
        "return roles | {Role.ROBOT} if inp is ACTION else roles", "return roles",
        f"{STEPS}::test_only_a_relation_to_an_entity_outside_the_affordance_is_held_back"),
    Bug("own-relations-creation-unranked", "hadim_cli/learner/adaptation.py",
        "best = max(options, key=rank)", "best = max(options, key=lambda o: o[0])",
        f"{STEPS}::test_a_tool_affordance_is_created_with_the_tools_relation_unless_the_robots"
        "_earns_it"),
    Bug("own-relations-review-baseline-unpenalised", "hadim_cli/learner/adaptation.py",
        "if margin < baseline - penalty(aff.contexts):", "if margin < baseline:",
        f"{STEPS}::test_a_tool_affordance_holds_the_robots_relation_only_while_it_earns_it"),
    Bug("own-relations-review-options-unpenalised", "hadim_cli/learner/adaptation.py",
        "              - penalty(contexts), value, kind, contexts, detail)",
        "              - 0.0, value, kind, contexts, detail)",
        f"{STEPS}::test_a_tool_affordance_holds_the_robots_relation_only_while_it_earns_it"),
    Bug("own-relations-legacy-forgotten", "hadim_cli/config.py",
        '"chain_objects": False,\n                "own_relations": False},',
        '"chain_objects": False},',
        "tests/test_config.py::"
        "test_a_run_stored_before_tools_were_chosen_by_their_chain_keeps_its_objects"),
    Bug("route-detour-ignored", "hadim_cli/learner/routes.py",
        "if not hit.size:", "if True:",
        f"{NAV}::test_the_way_round_a_disc_goes_along_its_tangents_and_its_arc "
        f"{NAV}::test_a_trip_goes_round_the_object_to_the_place_behind_it_facing_the_push"),
    Bug("route-disc-entered", "hadim_cli/learner/routes.py",
        "out |= (d < r) & (d < np.linalg.norm(before - c, axis=1) - 1e-4)",
        "out |= (d < r) & (d < -1.0)",
        f"{NAV}::test_a_trip_goes_round_the_object_to_the_place_behind_it_facing_the_push"),
    Bug("route-rim-radial", "hadim_cli/learner/routes.py",
        "np.where(on_rim, _rotate(u0, side * (np.pi / 2)),",
        "np.where(on_rim, unit(touch0 - frm[rows]),",
        f"{NAV}::test_the_way_round_a_disc_goes_along_its_tangents_and_its_arc"),
    Bug("route-approach-within", "hadim_cli/learner/navigation.py",
        "if obstacles is not None and obstacles.holds(start):", "if False:",
        f"{NAV}::test_a_trip_leaves_an_object_it_stands_against"),
    Bug("route-last-not-first", "hadim_cli/learner/routes.py",
        "first = np.tile(tried, pos.shape[0]) if d == 1 else origin[parent]",
        "first = np.tile(tried, pos.shape[0])",
        f"{NAV}::test_a_trip_goes_round_the_object_to_the_place_behind_it_facing_the_push"),
    Bug("route-search-off", "hadim_cli/learner/planner.py",
        "near, search=self.pc.route_search)", "near, search=False)",
        "tests/learner/test_planner.py::test_the_place_of_an_action_pusher_is_driven_to_facing_"
        "its_heading"),
    Bug("near-disc-not-shrunk", "hadim_cli/learner/planner.py",
        "radii[near - 1] = min(radii[near - 1],", "radii[near - 1] = max(radii[near - 1],",
        "tests/learner/test_planner.py::test_a_trip_keeps_out_of_every_object_and_reaches_the_"
        "one_it_is_taken_next_to"),
    Bug("avoid-disc-contact", "hadim_cli/learner/planner.py",
        "radii[b.avoid - 1] = self._avoid_distance(obs, b)",
        "radii[b.avoid - 1] = radii[b.avoid - 1]",
        "tests/learner/test_planner.py::test_a_trip_keeps_out_of_every_object_and_reaches_the_"
        "one_it_is_taken_next_to"),
    Bug("route-search-legacy-forgotten", "hadim_cli/config.py",
        '"near_pursuit": False, "route_search": False,', '"near_pursuit": False,',
        "tests/test_config.py::test_a_run_stored_before_trips_were_searched_keeps_its_waypoints"),
    Bug("stagings-not-spared", "hadim_cli/learner/planner.py",
        "return b.avoid >= 0 or (self.pc.spare_stagings and self._entity(aff.input, b) > 0)",
        "return b.avoid >= 0",
        f"{PL}::test_the_tool_level_spares_a_staging_for_a_small_remainder"),
    Bug("spare-stagings-ignored", "hadim_cli/learner/planner.py",
        "(self.pc.spare_stagings and self._entity(aff.input, b) > 0)",
        "(self._entity(aff.input, b) > 0)",
        f"{PL}::test_the_tool_level_spares_a_staging_for_a_small_remainder"),
    Bug("sb3-logs-to-temp", "hadim_cli/baselines/agents.py",
        "        self.model.set_logger(Logger(folder=None, output_formats=[]))\n", "",
        "tests/baselines/test_algorithms.py::"
        "test_learning_in_chunks_writes_nothing_to_the_temporary_directory"),
    Bug("pusher-contacts-ignored", "hadim_cli/learner/planner.py",
        "if self.pc.pusher_contacts and aff.contexts[i].relative_to is not pusher:",
        "if False:",
        f"{PL}::test_only_the_pushers_relation_is_brought_to_contact"),
    Bug("pusher-contacts-legacy-forgotten", "hadim_cli/config.py",
        '"spare_stagings": False,\n                "pusher_contacts": False,',
        '"spare_stagings": False,\n                ',
        "tests/test_config.py::test_a_run_stored_before_trips_were_searched_keeps_its_waypoints"),
    Bug("idle-repeats-allowed", "hadim_cli/learner/planner.py",
        "if not self.pc.skip_idle_repeats or self._idle is None:",
        "if True:",
        f"{PL}::test_an_action_that_moved_nothing_is_not_repeated_from_where_it_left"),
    Bug("idle-repeats-switch-ignored", "hadim_cli/learner/planner.py",
        "if not self.pc.skip_idle_repeats or self._idle is None:",
        "if self._idle is None:",
        f"{PL}::test_an_action_that_moved_nothing_is_not_repeated_from_where_it_left"),
    Bug("idle-never-recorded", "hadim_cli/learner/planner.py",
        "dtype=float) if self.pc.skip_idle_repeats else None", "dtype=float) if False else None",
        f"{PL}::test_an_action_that_moved_nothing_is_not_repeated_from_where_it_left"),
    Bug("idle-any-observation", "hadim_cli/learner/planner.py",
        "and np.allclose(obs, left, rtol=0.0, atol=IDLE_CHANGE))",
        "and obs is not None)",
        f"{PL}::test_an_action_that_moved_nothing_is_not_repeated_from_where_it_left"),
    Bug("idle-repeats-legacy-forgotten", "hadim_cli/config.py",
        '"pusher_contacts": False, "skip_idle_repeats": False,',
        '"pusher_contacts": False,',
        "tests/test_config.py::test_a_run_stored_before_trips_were_searched_keeps_its_waypoints"),
    Bug("drifting-places-ignored", "hadim_cli/learner/navigation.py",
        "if seen is None and self.config.drifting_places:", "if False:",
        "tests/learner/test_navigation.py::"
        "test_a_place_that_drifts_within_its_tolerance_is_still_given_up"),
    Bug("drifting-places-any-distance", "hadim_cli/learner/navigation.py",
        "found, nearest = None, place.tolerance", "found, nearest = None, np.inf",
        "tests/learner/test_navigation.py::"
        "test_a_place_that_drifts_within_its_tolerance_is_still_given_up"),
    Bug("drifting-places-legacy-forgotten", "hadim_cli/config.py",
        ',\n                "drifting_places": False, "face_places": False,',
        ', "face_places": False,',
        "tests/test_config.py::test_a_run_stored_before_trips_were_searched_keeps_its_waypoints"),
    Bug("unpinned-numpy-silent", "hadim_cli/numerics.py",
        "warnings.warn(UNPINNED, RuntimeWarning, stacklevel=3)", "pass",
        "tests/test_numerics.py::"
        "test_imported_after_numpy_it_warns_that_the_kernels_are_the_machines"),
    Bug("face-places-ignored", "hadim_cli/learner/planner.py",
        "elif (heading := self._unfaced(aff, b, delta, needed, obs)) is not None:",
        "elif False:",
        f"{PL}::test_a_trip_at_its_place_goes_on_until_the_robot_faces_its_push"),
    Bug("face-places-any-heading", "hadim_cli/learner/planner.py",
        "if float(line_angle(now[None], heading[None])[0]) <= self.pc.heading_tolerance:",
        "if False:",
        f"{PL}::test_a_trip_at_its_place_goes_on_until_the_robot_faces_its_push"),
    Bug("face-places-any-trip", "hadim_cli/learner/planner.py",
        "and self._navigating()\n                and aff.id in self._placed_for):",
        "and self._navigating()\n                and bool(self._placed_for)):",
        f"{PL}::test_a_trip_at_its_place_goes_on_until_the_robot_faces_its_push"),
    Bug("face-places-not-driven", "hadim_cli/learner/planner.py",
        "and not (\n                    facing is not None and driven == ROBOT_POSITION):",
        "and not (\n                    False):",
        f"{PL}::test_a_trip_that_only_turns_is_driven_with_its_heading"),
    Bug("face-places-legacy-forgotten", "hadim_cli/config.py",
        '"drifting_places": False, "face_places": False,', '"drifting_places": False,',
        "tests/test_config.py::test_a_run_stored_before_trips_were_searched_keeps_its_waypoints"),
    Bug("mirrored-relations-ignored", "hadim_cli/learner/planner.py",
        "if self.pc.mirrored_relations and (mirrored := self._mirrored(aff, ctx, y, delta)):",
        "if False and (mirrored := self._mirrored(aff, ctx, y, delta)):",
        f"{PL}::test_a_place_fitted_with_its_mirror_images_lies_on_the_line_of_its_push"),
    Bug("mirrored-relations-not-reflected", "hadim_cli/learner/planner.py",
        "image[:, sl] = ctx[:, sl] @ flip", "image[:, sl] = ctx[:, sl]",
        f"{PL}::test_mirror_images_reflect_outcomes_relations_and_headings_and_keep_sizes"),
    Bug("mirrored-relations-outcome-kept", "hadim_cli/learner/planner.py",
        "np.concatenate([y, y @ flip])", "np.concatenate([y, y])",
        f"{PL}::test_mirror_images_reflect_outcomes_relations_and_headings_and_keep_sizes"),
    Bug("mirrored-relations-heading-kept", "hadim_cli/learner/planner.py",
        "if turns_with_scene(aff.contexts[i])]",
        "if aff.contexts[i].relative_to is not None]",
        f"{PL}::test_mirror_images_reflect_outcomes_relations_and_headings_and_keep_sizes"),
    Bug("mirrored-relations-absolute", "hadim_cli/learner/planner.py",
        "if any(space.prop is Property.LIDAR or (space.prop is Property.POSITION\n"
        "                                                and space.relative_to is None)\n",
        "if any(space.prop is Property.LIDAR\n",
        f"{PL}::test_mirror_images_reflect_outcomes_relations_and_headings_and_keep_sizes"),
    Bug("mirrored-relations-legacy-forgotten", "hadim_cli/config.py",
        '"face_places": False,\n                "mirrored_relations": False, "convoy": False,',
        '"face_places": False,\n                "convoy": False,',
        "tests/test_config.py::test_a_run_stored_before_trips_were_searched_keeps_its_waypoints"),
    Bug("line-stagings-ignored", "hadim_cli/learner/planner.py",
        "if self.pc.line_stagings and mover_entity > 0 and not points:", "if False:",
        f"{PL}::test_a_tool_staged_round_the_target_goes_to_the_push_line_in_one_leg"),
    Bug("line-stagings-way-not-cleared", "hadim_cli/learner/planner.py",
        "            if self._first_obstacle(start, point, obs, obstacles, mover_radius) is None:\n"
        "                return [point, goal]",
        "            return [point, goal]",
        f"{PL}::test_a_tool_staged_round_the_target_goes_to_the_push_line_in_one_leg"),
    Bug("line-stagings-pusher-room-forgotten", "hadim_cli/learner/planner.py",
        "\n                    or np.any(np.abs(pusher) > half - robot_r - WALL_GAP)", "",
        f"{PL}::test_a_staging_whose_push_line_leaves_the_room_goes_round_on_the_arc"),
    Bug("direct-remainders-ignored", "hadim_cli/learner/planner.py",
        "if self.pc.direct_remainders and (float(np.linalg.norm(delta))",
        "if False and (float(np.linalg.norm(delta))",
        f"{PL}::test_the_last_stretch_of_an_object_input_is_pushed_by_the_inverse_answer"),
    Bug("convoy-pursues-the-line", "hadim_cli/learner/planner.py",
        "if self.pc.convoy and self._held_relation(", "if False and self._held_relation(",
        f"{PL}::test_a_convoy_moves_the_tool_along_the_targets_way_and_tells_its_pusher"),
    Bug("convoy-pusher-not-told", "hadim_cli/learner/planner.py",
        "outer, self._convoy_output = self._convoy_output, self._entity(aff.output, b)",
        "outer = self._convoy_output",
        f"{PL}::test_a_convoy_moves_the_tool_along_the_targets_way_and_tells_its_pusher"),
    Bug("convoy-pusher-told-for-good", "hadim_cli/learner/planner.py",
        "        finally:\n            self._convoy_output = outer\n",
        "        finally:\n            pass\n",
        f"{PL}::test_a_convoy_moves_the_tool_along_the_targets_way_and_tells_its_pusher"),
    Bug("convoy-pusher-inverse-answer", "hadim_cli/learner/planner.py",
        "        convoy = self._in_convoy(aff, b)\n", "        convoy = False\n",
        f"{PL}::test_the_robot_pushes_straight_in_a_convoy_and_by_the_inverse_answer_elsewhere"),
    Bug("convoy-staging-straight", "hadim_cli/learner/planner.py",
        "return (self._convoy_output >= 0 and b.avoid == self._convoy_output\n",
        "return (b.avoid >= 0\n",
        f"{PL}::test_the_robot_pushes_straight_in_a_convoy_and_by_the_inverse_answer_elsewhere"),
    Bug("straight-move-inverse-length", "hadim_cli/learner/planner.py",
        "return moves[int(np.argmin(np.linalg.norm(y - delta, axis=1)))].copy()",
        "return moves[6].copy()",
        f"{PL}::test_a_convoy_moves_the_tool_along_the_targets_way_and_tells_its_pusher "
        f"{PL}::test_the_robot_pushes_straight_in_a_convoy_and_by_the_inverse_answer_elsewhere"),
    Bug("convoy-facing-ignored", "hadim_cli/learner/planner.py",
        "Place(goal, _unit_heading(x) if facing else None,", "Place(goal, None,",
        f"{PL}::test_the_robots_convoy_push_is_a_pose_facing_the_push_and_elsewhere_a_place"),
    Bug("convoy-facing-every-push", "hadim_cli/learner/planner.py",
        "facing=convoy and self.pc.convoy_facing)", "facing=self.pc.convoy_facing)",
        f"{PL}::test_the_robots_convoy_push_is_a_pose_facing_the_push_and_elsewhere_a_place"),
    Bug("convoy-facing-option-ignored", "hadim_cli/learner/planner.py",
        "facing=convoy and self.pc.convoy_facing)", "facing=convoy)",
        f"{PL}::test_the_robots_convoy_push_is_a_pose_facing_the_push_and_elsewhere_a_place"),
    Bug("convoy-facing-legacy-forgotten", "hadim_cli/config.py",
        '"convoy": False,\n                "convoy_facing": False,', '"convoy": False,',
        "tests/test_config.py::test_a_run_stored_before_trips_were_searched_keeps_its_waypoints"),
    Bug("short-subgoals-ignored", "hadim_cli/learner/planner.py",
        "scale = min(step, start) if self.pc.short_subgoals else step", "scale = step",
        f"{PL}::test_a_subgoal_shorter_than_a_step_is_held_to_a_share_of_its_own_length"),
    Bug("short-subgoals-option-ignored", "hadim_cli/learner/planner.py",
        "scale = min(step, start) if self.pc.short_subgoals else step",
        "scale = min(step, start)",
        f"{PL}::test_a_subgoal_shorter_than_a_step_is_held_to_a_share_of_its_own_length"),
    Bug("short-subgoals-legacy-forgotten", "hadim_cli/config.py",
        '"convoy_facing": False, "short_subgoals": False},', '"convoy_facing": False},',
        "tests/test_config.py::test_a_run_stored_before_trips_were_searched_keeps_its_waypoints"),
    Bug("convoy-legacy-forgotten", "hadim_cli/config.py",
        '"mirrored_relations": False, "convoy": False,', '"mirrored_relations": False,',
        "tests/test_config.py::test_a_run_stored_before_trips_were_searched_keeps_its_waypoints"),
    Bug("spare-stagings-legacy-forgotten", "hadim_cli/config.py",
        '"route_search": False, "spare_stagings": False,', '"route_search": False,',
        "tests/test_config.py::test_a_run_stored_before_trips_were_searched_keeps_its_waypoints"),
)


def unplantable(bug: Bug) -> str | None:
    """Why `bug` cannot be planted (None: it can): its text does not occur exactly once in its
    file (an edit of the code moved it), or the file does not compile with it planted."""
    source = (ROOT / bug.path).read_text()
    if source.count(bug.old) != 1:
        return f"the text to replace occurs {source.count(bug.old)} times in {bug.path}"
    if bug.path.endswith(".py"):
        try:
            compile(source.replace(bug.old, bug.new), bug.path, "exec")
        except SyntaxError as exc:
            return f"{bug.path} does not compile with it planted ({exc.msg})"
    return None


def plant(bug: Bug) -> str:
    """'caught' if the tests failed on `bug`, 'MISSED' if they passed, 'BROKEN' if they could
    not run (the bug does not even import: it proves nothing)."""
    path = ROOT / bug.path
    source = path.read_text()
    if (why := unplantable(bug)) is not None:
        raise SystemExit(f"error: bug {bug.name}: {why}")
    try:
        path.write_text(source.replace(bug.old, bug.new))
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        result = subprocess.run([sys.executable, "-m", "pytest", "-q", "-x", "-p",
                                 "no:cacheprovider", *bug.tests.split()], cwd=ROOT, env=env,
                                capture_output=True, text=True)
    finally:
        path.write_text(source)
    return {0: "MISSED", 1: "caught"}.get(result.returncode, "BROKEN")


def main(names: list[str]) -> int:
    chosen = [b for b in BUGS if not names or b.name in names]
    unknown = set(names) - {b.name for b in BUGS}
    if unknown:
        print(f"error: unknown bug(s): {', '.join(sorted(unknown))}", file=sys.stderr)
        return 2
    missed = []
    for bug in chosen:
        verdict = plant(bug)
        print(f"{verdict:7s} {bug.name}", flush=True)
        if verdict != "caught":
            missed.append(bug.name)
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
