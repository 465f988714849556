"""Every test module under the capability it specifies: `pytest -m NAME` runs one capability's
tests across the folders (which group them by layer: protocol/, robot/, physics/, server/, ...).
conftest.py marks each collected test; test_capabilities.py fails on a module named nowhere or
twice, so a new test module is placed on purpose."""

CAPABILITIES = {
    "connect": "connecting, the handshake and the state stream",
    "wire": "the wire format: structs, codec, framing, golden bytes",
    "motion": "motions, the command cycle and its window, the clock (realtime and lockstep)",
    "limits": "motion limits, safety, the IK's joint side",
    "forces": "external forces, loads, contact",
    "physics": "the MuJoCo world: the arm, the scene, bodies, the model a client builds, the "
               "cycle's compiled kernels",
    "engines": "the physics engines: choosing one, the same clients on MuJoCo and Genesis",
    "tools": "the end-effector tool seam, the Franka Hand and the vacuum gripper",
    "faults": "network faults on purpose, lost commands",
    "several_arms": "worlds of several arms and the mobile duo",
    "recording": "recording, replay, plot, render",
    "control_api": "the control API",
    "robustness": "hostile input, dead peers, a simulator that stops simulating",
    "serving": "the CLI, readiness checks, embedding, the process, the viewer",
    "clients": "real clients end to end and the programs in examples/",
    "versions": "older libfranka: robot protocol versions before 10, the model library, the "
                "Panda (FER) they were made for",
    "plugin": "the pytest plugin as a user meets it",
    "deployment": "the image, compose, Kubernetes, the GitHub action",
    "combinations": "the serve flags in combination",
    "desk": "the Desk, the robot's web API: its dialects, clients and effects on the robot",
    "viewing": "the web view (live, in a headless browser) and how the arm looks in it and "
               "in a render",
}

MODULES = {
    "viewing": ["web/test_web_view.py", "web/test_web_serving.py", "web/test_arm_look.py",
                "web/test_recording_view.py", "web/test_snapshots.py",
                "web/test_meshes.py"],
    "versions": ["protocol/test_robot_v9.py", "protocol/test_robot_v5.py",
                 "physics/test_model_library.py", "physics/test_model_library_targets.py",
                 "clients/test_older_libfranka.py",
                 "clients/test_panda_python.py", "clients/test_panda_arm.py",
                 "robot/test_fer_limits.py", "clients/test_libfranka_cpp_older.py",
                 "recording/test_libfranka_cpp_recordings.py",
                 "recording/test_older_clients_json.py"],
    "connect": ["server/test_connect.py", "server/test_state.py", "server/test_raw_modes.py",
                "server/test_udp_endpoint.py", "clients/test_address_translation.py"],
    "wire": ["protocol/test_protocol_codec.py", "protocol/test_protocol_framing.py",
             "protocol/test_protocol_golden.py", "protocol/test_protocol_structs.py"],
    "motion": ["robot/test_command_cycle.py", "robot/test_command_window.py",
               "robot/test_consecutive_motions.py", "robot/test_motion.py",
               "robot/test_motion_cartesian.py", "server/test_pacing.py",
               "server/test_lockstep_idle.py", "server/test_determinism.py",
               "server/test_cycle_thread.py", "clients/test_lockstep_time.py"],
    "limits": ["robot/test_limits.py", "robot/test_limits_raw.py", "robot/test_ik_limits.py",
               "robot/test_safety.py", "clients/test_limits_client.py",
               "clients/test_examples_strict.py"],
    "forces": ["robot/test_external_forces.py", "robot/test_load.py",
               "clients/test_external_forces_client.py", "clients/test_load_client.py",
               "clients/test_contact_buildup_client.py", "clients/test_friction_client.py"],
    "engines": ["engines/test_engine_choice.py", "engines/test_same_clients.py"],
    "physics": ["physics/test_physics.py", "physics/test_model.py", "physics/test_description.py",
                "physics/test_scene.py", "physics/test_world.py", "physics/test_bodies.py",
                "physics/test_kernels.py"],
    "tools": ["tools/test_tool_seam.py", "robot/test_gripper_core.py",
              "physics/test_gripper_physics.py", "clients/test_gripper.py",
              "clients/test_grasp_centred.py", "robot/test_vacuum_gripper.py",
              "physics/test_suction.py", "clients/test_panda_python_vacuum.py",
              "clients/test_libfranka_cpp_vacuum.py"],
    "faults": ["server/test_faults.py", "control/test_control_faults.py",
               "clients/test_network_faults_client.py", "robot/test_lost_commands.py",
               "clients/test_lost_commands_client.py"],
    "several_arms": ["robot/test_world_cycle.py", "clients/test_several_arms.py",
                     "clients/test_bimanual.py", "control/test_control_several_arms.py",
                     "server/test_arms_bad_input.py", "mobile/test_base_core.py",
                     "mobile/test_mobile_world.py", "mobile/test_mobile_duo_client.py",
                     "mobile/test_base_control_api.py"],
    "recording": ["recording/test_record_replay.py", "recording/test_live_recording.py",
                  "recording/test_command_fates.py", "recording/test_plot_render.py",
                  "recording/test_without_mcap.py", "recording/test_examples_replay.py"],
    "control_api": ["control/test_control_bad_input.py", "control/test_control_lockstep_changes.py",
                    "control/test_control_reset.py", "control/test_control_resources.py",
                    "control/test_control_serving.py", "control/test_operations_table.py"],
    "robustness": ["protocol/test_bad_input.py", "protocol/test_bad_input_vacuum.py",
                   "protocol/test_fuzz_decoders.py",
                   "protocol/test_fuzz_sessions.py", "server/test_hostile_peers.py",
                   "server/test_hostile_peers_netns.py", "server/test_failure.py"],
    "serving": ["server/test_cli.py", "server/test_check.py", "server/test_embedding.py",
                "server/test_footprint.py", "server/test_status_line.py",
                "server/test_viewer.py"],
    "clients": ["clients/test_client_franky.py", "clients/test_client_franka_rs.py",
                "clients/test_examples.py", "clients/test_pick_and_place.py",
                "clients/test_pick_and_place_reading_ahead.py"],
    "plugin": ["plugin/test_plugin.py", "plugin/test_recording.py",
               "plugin/test_worked_example.py"],
    "deployment": ["container/test_action.py", "container/test_deploy_files.py",
                   "container/test_image.py", "container/test_pid1.py"],
    "combinations": ["combinations/test_combination_runs.py",
                     "combinations/test_matrix_factors.py"],
    "desk": ["desk/test_desk_state.py", "desk/test_desk_clients.py",
             "desk/test_desk_bad_input.py", "desk/test_desk_recording.py",
             "desk/test_desk_serving.py", "desk/test_desk_lock_unlock.py"],
}


def capability_of(module: str) -> str | None:
    """The capability of a test module (its path under tests/, with '/')."""
    for name, modules in MODULES.items():
        if module in modules:
            return name
    return None
