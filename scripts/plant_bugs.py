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
CUR = "tests/baselines/test_curious.py"


class Bug(NamedTuple):
    name: str
    path: str
    old: str
    new: str
    tests: str
    """pytest node ids (space-separated) that must fail."""


BUGS = (
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
    Bug("untried-interest-ignored", "hadim_cli/learner/explorer.py",
        "if self.config.untried_interest:", "if False:",
        STEPS + "::test_an_affordance_tried_on_few_goals_is_practised_with_untried_interest"),
    Bug("untried-interest-forever", "hadim_cli/learner/explorer.py",
        "if a.interest.n_goals < self.config.interest_window else i",
        "if a.interest.n_goals >= 0 else i",
        STEPS + "::test_an_affordance_tried_on_few_goals_is_practised_with_untried_interest"),
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
        "open_all=self.config.open_contexts)",
        "open_all=False)",
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
    Bug("robot-only-counts-pushes", "hadim_cli/evaluation/runner.py",
        "- objects, axis=1) < MOVED))",
        "- objects, axis=1) < 1.0))",
        "tests/test_eval_diagnostics.py::test_an_action_counts_as_robot_only_unless_it_moves_"
        "an_object"),
    Bug("robot-only-after-always", "hadim_cli/evaluation/runner.py",
        "self.robot_only_after += still and self.first_push is not None",
        "self.robot_only_after += still",
        "tests/test_eval_diagnostics.py::test_robot_only_actions_after_the_pushed_object_first_"
        "moved_are_counted_apart"),
    Bug("robot-only-after-every-action", "hadim_cli/evaluation/runner.py",
        "self.robot_only_after += still and self.first_push is not None",
        "self.robot_only_after += self.first_push is not None",
        "tests/test_eval_diagnostics.py::test_robot_only_actions_after_the_pushed_object_first_"
        "moved_are_counted_apart"),
    Bug("affordance-moved-every-row", "hadim_cli/reports.py",
        '"effect": int(moved.sum()), "goals": aff.interest.n_goals,',
        '"effect": int(len(moved)), "goals": aff.interest.n_goals,',
        "tests/test_cli.py::test_affordances_count_where_each_acts_and_its_goals"),
    Bug("affordance-goals-regions", "hadim_cli/reports.py",
        '"effect": int(moved.sum()), "goals": aff.interest.n_goals,',
        '"effect": int(moved.sum()), "goals": aff.interest.n_regions,',
        "tests/test_cli.py::test_affordances_count_where_each_acts_and_its_goals"),
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
    Bug("remaining-share-from-the-start", "hadim_cli/evaluation/metric.py",
        "return float(np.linalg.norm(np.subtract(target, position))) / max(initial, 1e-12)",
        "return float(np.linalg.norm(np.subtract(position, start))) / max(initial, 1e-12)",
        "tests/test_evaluation.py::test_the_remaining_share_is_the_error_so_far_unclipped"),
    Bug("kernels-not-pinned", "hadim_cli/numerics.py",
        "        os.environ.setdefault(key, value)",
        "        pass",
        "tests/test_numerics.py::test_importing_hadim_first_pins_every_library_to_avx2_kernels"),
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
    Bug("sb3-logs-to-temp", "hadim_cli/baselines/agents.py",
        "        self.model.set_logger(Logger(folder=None, output_formats=[]))\n", "",
        "tests/baselines/test_algorithms.py::"
        "test_learning_in_chunks_writes_nothing_to_the_temporary_directory"),
    Bug("unpinned-numpy-silent", "hadim_cli/numerics.py",
        "warnings.warn(UNPINNED, RuntimeWarning, stacklevel=3)", "pass",
        "tests/test_numerics.py::"
        "test_imported_after_numpy_it_warns_that_the_kernels_are_the_machines"),
    # CURIOUS (Colas et al. 2019), each mechanism (issue 46)
    Bug("curious-lp-shares-swapped", "hadim_cli/baselines/curious.py",
        "return UNIFORM_SHARE / n + (1 - UNIFORM_SHARE) * np.asarray(lps) / total",
        "return (1 - UNIFORM_SHARE) / n + UNIFORM_SHARE * np.asarray(lps) / total",
        "tests/baselines/test_algorithms.py::test_learning_progress_and_module_probabilities"),
    Bug("curious-her-keeps-module", "hadim_cli/baselines/curious.py",
        "modules = np.random.choice(n, size=len(batch_indices), p=probs)",
        "modules = obs['desired_goal'][:, 2 * n:].argmax(axis=1)",
        f"{CUR}::test_modular_her_relabels_module_and_a_future_goal_of_the_same_episode"),
    Bug("curious-her-any-step", "hadim_cli/baselines/curious.py",
        "return (np.random.randint(current, length) + start) % self.buffer_size",
        "return (np.random.randint(0, length) + start) % self.buffer_size",
        f"{CUR}::test_modular_her_relabels_module_and_a_future_goal_of_the_same_episode"),
    Bug("curious-her-final-step", "hadim_cli/baselines/curious.py",
        "return (np.random.randint(current, length) + start) % self.buffer_size",
        "return (length - 1 + start) % self.buffer_size",
        f"{CUR}::test_modular_her_relabels_module_and_a_future_goal_of_the_same_episode"),
    Bug("curious-her-achieved-not-reencoded", "hadim_cli/baselines/curious.py",
        'nxt["achieved_goal"] = encode_goals(entity_positions(nxt["observation"], modules),',
        'nxt["achieved_goal"] = nxt["achieved_goal"] + 0 * encode_goals(entity_positions('
        'nxt["observation"], modules),',
        f"{CUR}::test_modular_her_relabels_module_and_a_future_goal_of_the_same_episode"),
    Bug("curious-descriptor-misplaced", "hadim_cli/baselines/curious.py",
        "out[rows, 2 * n_modules + modules] = 1.0", "out[rows, 2 * n_modules] = 1.0",
        f"{CUR}::test_encoding_of_many_goals_is_the_env_encoding"),
    Bug("curious-wrong-entity", "hadim_cli/baselines/curious.py",
        "start = np.where(modules == 0, 0, 2 + 2 * modules)",
        "start = np.where(modules == 0, 0, 4 + 2 * modules)",
        f"{CUR}::test_encoding_of_many_goals_is_the_env_encoding"),
    Bug("curious-k-not-4", "hadim_cli/baselines/config.py",
        'HER_PARAMS: dict[str, Any] = {"n_sampled_goal": 4,',
        'HER_PARAMS: dict[str, Any] = {"n_sampled_goal": 2,',
        f"{CUR}::test_modular_her_replays_four_relabelled_transitions_per_real_one"),
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
