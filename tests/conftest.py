"""The two tiers of the suite.

- the fast tier, for your own loop: `python -m pytest -q -n auto -m "not slow"`;
- the whole suite, as CI runs it: `python -m pytest -q -n auto`.

A test is slow when it is marked `@pytest.mark.slow` where it is written, when its module is
slow by nature (SLOW_MODULES: numba compiling kernels, real processes and their signals, the
fuzzers, the docs' commands), or when it is named in SLOW_TESTS: the tests that cost about a
second of CPU or more each (the list is checked against each module it names, so a renamed test
does not drop out of it silently). What the tiers cost is measured, not asserted: the README
gives the figures."""

import pytest

SLOW_MODULES = {
    "test_batch", "test_compiled", "test_compiled_gen", "test_perstep",    # numba compiles
    "test_contract", "test_execute", "test_plotworker", "test_interrupts",  # real processes
    "test_synth_jobs",
    "test_dask_errors",                                                     # servers, clusters
    "test_fuzz", "test_properties", "test_extremes", "test_sketch_fuzz",    # generated inputs
    "test_docs",                                                            # the docs' commands
}

SLOW_TESTS = {
    "test_bigblocks": {"test_many_small_blocks_get_larger_chunks_within_their_bound",
                       "test_sparse_and_dense_blocks_agree"},
    "test_branches": {"test_branch_that_leaves_a_downstream_loop_open_is_refused",
                      "test_jansen_every_branch_combination"},
    "test_breakpoints": {"test_grid_rows_against_closed_form"},
    "test_budget": {"test_budget_can_be_raised_and_is_honoured_on_the_path",
                    "test_ordinary_drivers_pass_the_preflight"},
    "test_cam_data_laws": {"test_rise_dwell_return_segments_over_cam_angle"},
    "test_centres": {"test_centrodes_figure"},
    "test_cli": {"test_plot_formats", "test_tradeoff_writes_table_and_plot",
                 "test_run_junit_has_a_case_per_model_failure_error_and_time"},
    "test_closedforms": {"test_four_bar_against_a_50_digit_solution"},
    "test_compare": {"test_two_roots_of_20_models_give_one_line_each_and_exit_0"},
    "test_contact_forces": {"test_every_body_of_the_machine_element_examples_obeys_newton_euler"},
    "test_curve_segments": {"test_curve_table_from_a_file_equals_the_inline_table"},
    "test_fastcsv": {"test_random_bit_patterns", "test_random_uniform"},
    "test_figures": {"test_a_cam_or_a_disc_is_drawn_by_its_outline_not_as_a_slider_block",
                     "test_measures_png_leaves_the_callers_matplotlib_backend_alone"},
    "test_budgets_hostile": {"test_plots_of_many_points_draw_a_bounded_number_of_artists"},
    "test_cycle_dwells": {
        "test_tolerance_nominal_equals_run_and_its_sensitivities_are_the_metrics_derivatives"},
    "test_fit": {"test_cli_fit_writes_estimates", "test_fit_the_slider_crank_and_the_six_bar",
                 "test_noisy_data_true_within_two_standard_errors",
                 "test_fit_and_run_in_the_same_out_keep_each_others_files"},
    "test_export": {"test_valve_cam_profile_within_the_tolerance_and_says_it",
                    "test_the_fit_holds_its_tolerance_on_an_ellipse"},
    "test_forces": {"test_machine_elements_balance_on_their_bodies"},
    "test_hostile": {"test_a_table_over_the_row_budget_is_refused_while_it_is_read"},
    "test_hostile_checks": {"test_segments_long_enough_still_run"},
    "test_imports": {"test_no_import_cycles", "test_no_private_names_across_modules"},
    "test_jerk": {"test_every_example_runs_with_jerk",
                  "test_jerk_is_the_time_derivative_of_the_gamma_identity",
                  "test_servo_axis_jerk_is_the_profile_third_derivative"},
    "test_lockup": {"test_check_and_run_warn_of_a_lock_up_with_the_limit_angle"},
    "test_machine_elements": {"test_pin_leaving_an_open_slot_stops_the_run"},
    "test_plots": {"test_a_figure_does_not_depend_on_what_was_drawn_before",
                   "test_a_run_without_plots_never_imports_matplotlib", "test_animation_gif",
                   "test_cli_draws_the_plots_in_process", "test_failed_run_marks_the_stopping_time",
                   "test_time_histories_against_the_driver_coordinate"},
    "test_reference": {"test_slider_crank_grid_independence"},
    "test_report_html": {"test_in_a_browser_the_page_asks_nothing_and_its_scrubber_moves_the_drawing",
                         "test_in_a_browser_the_index_links_open", "test_mp4_has_the_gifs_frames"},
    "test_sketch": {"test_sketch_matches_body_joint_form"},
    "test_sketch_collinear": {"test_a_pin_drawn_on_the_line_stays_on_it"},
    "test_sketch_exact": {"test_every_form_matches_the_exact_linkage"},
    "test_sweep": {"test_a_sweeps_files_are_replaced_all_or_none",
                   "test_four_bar_sweep_metrics_match_the_closed_form"},
    "test_synth": {"test_cli_synth_writes_ready_to_run_designs",
                   "test_cli_synth_none_acceptable_exits_1",
                   "test_jacobian_angle_joint_constant_and_relative_driver",
                   "test_jacobian_motion_generation",
                   "test_jacobian_prescribed_inputs_through_a_driver_that_depends_on_p",
                   "test_jacobian_revolute_path_free_timing",
                   "test_jacobian_translational_function_generation",
                   "test_path_with_timing_finds_the_model_again",
                   "test_points_out_of_reach_end_with_the_best_design_and_exit_1",
                   "test_synth_and_run_in_the_same_out_keep_each_others_files",
                   "test_synth_finds_the_slider_crank_and_the_six_bar_again",
                   "test_turns_barrier_row_and_its_gradient"},
    "test_synth_budget": {"test_a_closed_curve_is_in_order_around_one_turn",
                          "test_the_evaluation_budget_is_used_to_the_last_evaluation",
                          "test_the_same_seed_gives_the_same_result",
                          "test_closed_true_without_the_repeat"},
    "test_synth_hostile": {"test_sigterm_to_synth_leaves_nothing_staged_and_says_what_happened",
                           "test_only_the_starts_that_can_be_run_are_held_whole"},
    "test_synth_local": {"test_starts_in_batches_end_at_the_first_design_below_the_goal",
                         "test_straight_line_reaches_1e_12_from_a_known_linkage_and_is_verified",
                         "test_a_start_out_of_order_is_run_but_never_returned"},
    "test_synth_sensitivities": {"test_parameters_not_differentiated_are_refused_by_name",
                                 "test_sensitivities_match_central_differences",
                                 "test_parameter_derivatives_are_the_same_bits_in_every_process"},
    "test_synth_starts": {"test_designs_the_follower_refuses_are_never_accepted",
                          "test_a_marched_design_has_the_followers_rows_to_rounding",
                          "test_a_search_scores_its_starts_as_one_by_one",
                          "test_the_starts_ahead_do_not_change_the_search",
                          "test_a_driver_with_a_breakpoint_is_left_to_the_follower"},
    "test_tolerance": {"test_first_order_spread_matches_the_monte_carlo_spread"},
    "test_yamlread": {"test_5mb_valid_file", "test_absurd_nesting_fails_fast",
                      "test_billion_laughs_fails_fast", "test_huge_files_of_nothing_fail_fast",
                      "test_mutated_models_never_raise_anything_but_input_error"},
}


def pytest_collection_modifyitems(config, items):
    seen: dict[str, set] = {}
    for item in items:
        module = item.module.__name__.rpartition(".")[2] if item.module else ""
        name = getattr(item, "originalname", item.name)
        seen.setdefault(module, set()).add(name)
        if module in SLOW_MODULES or name in SLOW_TESTS.get(module, ()):
            item.add_marker(pytest.mark.slow)
    # a module collected whole (no -k, no node id) must still hold every test the list names
    if not config.option.keyword and not any("::" in a for a in config.args):
        for module, names in SLOW_TESTS.items():
            if module in seen and names - seen[module]:
                raise pytest.UsageError(f"tests/conftest.py: SLOW_TESTS names tests that "
                                        f"{module}.py does not hold: "
                                        f"{', '.join(sorted(names - seen[module]))}")


@pytest.fixture(autouse=True)
def no_earlier_jobs_counted(monkeypatch):
    """Every test starts with none of its worker's earlier jobs counted towards the compiled
    route (kernel.route adds up a process's large jobs of one structure), so that the route a
    test's job takes never depends on the tests that ran before it."""
    from planarkin.solver.compiled import kernel
    monkeypatch.setitem(kernel._state, "points", {})
