"""Hook specifications: the whole contract between armtree and its plugins.

This module is the reference for plugin authors. A plugin is a module (or
object) with functions marked ``@armtree.hookimpl`` whose names match the hooks
below. armtree finds plugins in three places: the ``armtree`` entry-point group
of installed distributions, ``--plugin MODULE_OR_FILE`` on the command line, and
a ``plugins:`` list in a tree or profile. ``-p no:NAME`` blocks one; setting
``ARMTREE_DISABLE_PLUGIN_AUTOLOAD`` skips third-party entry points.

A plugin implements only the hooks it needs. Argument names must match the
specification (pluggy checks them when the plugin is registered), and every
component a registration hook returns is checked against the interface armtree
calls it through when the registry is built (:mod:`armtree.hooks.plugin_checks`;
``armtree plugins --check`` runs the deeper checks too). A plugin module may
name the armtree versions it supports, ``ARMTREE_REQUIRES = ">=0.1,<0.2"``;
a plugin that does not support the installed armtree is refused.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import pluggy

if TYPE_CHECKING:
    import argparse
    from pathlib import Path

    from armtree.api.outcomes.truth import WorldTruth
    from armtree.api.rig import Rig, RigContext
    from armtree.api.sweep import Sweep
    from armtree.api.worldview import SceneObject
    from armtree.config.profile_sections import ProfileSection
    from armtree.errors import ConfigError
    from armtree.loader.profile import Profile
    from armtree.runtime.run_end import RunResult
    from armtree.runtime.runner import Run

hookspec = pluggy.HookspecMarker("armtree")
hookimpl = pluggy.HookimplMarker("armtree")

# ---------------------------------------------------------------------------
# Registration: called once when the plugin manager builds its registry.
# Each returns ``{name: factory}``; the dicts of all plugins are merged and a
# name registered by two plugins is an error naming both.
# ---------------------------------------------------------------------------


@hookspec
def armtree_behaviours() -> dict[str, Any]:
    """Register behaviours usable as node types in tree files.

    :return: ``{node_type: factory}`` where ``node_type`` is the snake_case key
        used in YAML and ``factory`` is a :class:`armtree.Behaviour` subclass.
        Its ``PARAMS`` (a tuple of :class:`armtree.Param`) declares every
        parameter, so the loader validates trees before anything runs; its
        docstring's first line is the description ``armtree plugins`` shows.
        The loader builds a node as ``factory(name, **params)`` with every
        declared parameter (defaults filled in, ``"{key}"`` as a
        :class:`armtree.Binding`). A plain :class:`py_trees.behaviour.Behaviour`
        subclass without ``PARAMS`` works as it is: its parameters are its
        constructor's (names, defaults, types from annotations; unannotated ones
        take any YAML value), checked the same way. A py_trees ``Decorator`` or
        ``Composite`` subclass (or any callable whose ``KIND`` is ``"decorator"``
        or ``"composite"``) also receives ``child=`` or ``children=``; only
        :class:`armtree.Behaviour` subclasses accept bindings.

    Called once per plugin-manager, when the registry is first needed.
    """


@hookspec
def armtree_arms() -> dict[str, Any]:
    """Register arm types for a profile's ``arm: {type: ...}``.

    :return: ``{type: factory}``; ``factory(config, context)`` receives the
        profile's ``arm`` mapping (validated against ``factory.PARAMS`` when the
        factory declares them) and a :class:`armtree.api.rig.RigContext`, and returns
        a connected-on-demand :class:`armtree.api.rig.ArmDriver`. A factory may also
        offer ``factory.model(config)`` returning the arm's
        :class:`armtree.maths.motion.kinematics.KinematicModel` without opening a port.
    """


@hookspec
def armtree_cameras() -> dict[str, Any]:
    """Register camera types for a profile's ``camera: {type: ...}``.

    :return: ``{type: factory}``; ``factory(config, context)`` returns an
        :class:`armtree.api.rig.Camera`.
    """


@hookspec
def armtree_trackers() -> dict[str, Any]:
    """Register marker trackers for a profile's ``tracker: {type: ...}``.

    :return: ``{type: factory}``; ``factory(config, context)`` returns an
        :class:`armtree.api.rig.Tracker`.
    """


@hookspec
def armtree_planners() -> dict[str, Any]:
    """Register motion planners for a profile's ``planner: {type: ...}``.

    :return: ``{type: factory}``; ``factory(config, context, model, scene)``
        returns an :class:`armtree.api.rig.Planner` for the arm ``model`` among the
        obstacles of ``scene``.
    """


@hookspec
def armtree_predicates() -> dict[str, Any]:
    """Register predicates for the ``expect:`` list of tree files.

    :return: ``{key: predicate}``; ``key`` is what an entry writes to use it
        (``{object: ducky, upright: true}`` uses ``upright``) and ``predicate``
        an :class:`armtree.api.outcomes.predicates.Predicate` (or a subclass, instantiated once).
        Its ``SUBJECT`` says whether entries name ``object:``/``objects:``,
        ``VALUE`` and ``OPTIONS`` give the JSON Schema of the key's value and of
        further keys, ``check(entry, world)`` returns load-time problems against
        the nominal world and ``judge(entry, obj, world)`` a
        :class:`armtree.api.outcomes.predicates.Judgement` on the ground truth at the end of a
        run (once per object, or once with ``obj=None``). Plugin data for it
        travels in ``WorldTruth.extra``. The built-in keys (``on``, ``in``,
        ``at``, ``held``, ``collisions``, ``missed_steps``, ``parked``,
        ``tool_within_mm``) cannot be taken.
    """


@hookspec
def armtree_commands() -> dict[str, Any]:
    """Add subcommands to the ``armtree`` command line.

    :return: ``{name: command}``; ``command.help`` is a one-line summary,
        ``command.configure(parser)`` adds arguments to an
        :class:`argparse.ArgumentParser` (``configure(parser, manager)`` is also
        handed the plugin manager, for options that plugins add) and
        ``command.run(args)`` returns the exit code (0 ok, 1 failed, 2 bad input,
        3 hardware fault).
    """


@hookspec
def armtree_profile_sections() -> dict[str, ProfileSection]:
    """Register top-level hardware-profile sections that this plugin owns.

    armtree knows the sections every rig has (``arm``, ``camera``, ``tracker``,
    ``planner``, ``tags``, ``places``, ``table``, ``obstacles``, ``workcell``,
    ``calibration``, ``plugins``, ``watchdog``, ``include``). A section only one
    plugin reads, such as the built-in simulation's ``world:``, is registered here,
    and from then on a profile may have it:

    * the profile loader accepts it (else "unknown profile section"), checks its
      value against ``section.schema["type"]`` (an error at its file, line and
      column) and calls ``section.check(profile)`` for the rest;
    * ``--set SECTION.KEY=VALUE`` changes it, like armtree's own sections;
    * ``armtree schema`` puts ``section.schema`` under the profile's properties,
      so editors complete and check it.

    :return: ``{section_name: ProfileSection}`` (:class:`armtree.config.profile_sections.ProfileSection`).
        A name armtree or another plugin already uses is an error naming both.
    """


# ---------------------------------------------------------------------------
# Tree formats: a tree file in a format other than YAML.
# ---------------------------------------------------------------------------


@hookspec(firstresult=True)
def armtree_read_tree(path: Path) -> Any | None:
    """Read a tree file that is not YAML into the data a YAML tree file gives.

    :param path: the tree file (its suffix is not ``.yaml`` or ``.yml``). A path
        whose name ends in ``#ID`` (``tree.xml#search``) asks for the tree ``ID``
        of a file that holds several; a ``subtree:`` node names one with
        ``file: "#ID"`` (in the including file) or ``file: "other.xml#ID"``.
    :return: the tree file's top-level mapping as :func:`armtree.config.yamlio.load_yaml`
        gives it (:class:`~armtree.config.yamlio.MarkedDict` and
        :class:`~armtree.config.yamlio.MarkedList` carrying the position of every key and
        value in ``path``), or None when this plugin does not read the format (the
        file is then read as YAML). The first answer that is not None is used.
        Every check and positioned error of the loader applies to it unchanged.

    Raise :class:`armtree.ConfigError` (with file, line and column) for a file
    that cannot be read. Must not open ports or devices.
    """


# ---------------------------------------------------------------------------
# Validation: called while a profile loads, before anything is built.
# ---------------------------------------------------------------------------


@hookspec
def armtree_validate_profile(profile: Profile) -> list[ConfigError] | None:
    """Check the parts of a hardware profile this plugin owns, so ``armtree check`` finds them.

    :func:`armtree.load_profile` calls every implementation after its own checks
    (known sections, components against their ``PARAMS``, tags, places,
    obstacles, the planning scene) and raises one :class:`armtree.ConfigError`
    holding its own errors and the plugins' together, ordered by position. So a
    problem the plugin would otherwise only find when the rig is built (an arm
    swapped with ``--set arm.type=X`` that cannot reach the profile's places) is
    reported before anything moves. A section the plugin owns is checked by its
    :class:`~armtree.config.profile_sections.ProfileSection` instead
    (``armtree_profile_sections``).

    :param profile: the :class:`armtree.loader.profile.Profile` as loaded (overrides
        applied). ``profile.error("world.objects.box", "...")`` makes an error at
        that entry's file, line and column. ``profile.invalid`` names the
        top-level sections that already failed armtree's own checks: skip the
        checks that read them, so one mistake is not reported twice.
    :return: the problems found (``None`` or ``[]`` when there are none). Raising
        a ``ConfigError`` reports it the same way. Any other exception is
        reported as an error of the plugin, unless the profile already has errors
        (then it is taken to follow from them and dropped).

    Must not open ports or devices and must not change the profile.
    """


@hookspec
def armtree_rig_ready(rig: Rig, context: RigContext) -> None:
    """Every component of a rig has been built; wire components that work together.

    :param rig: the :class:`armtree.api.rig.Rig` about to be handed to the tree.
    :param context: the :class:`armtree.api.rig.RigContext` its factories shared;
        append to ``context.steppers`` to be advanced every tick.

    The built-in simulation uses it to put the emulated arm into its world. A
    plugin that drives a tool of its own (a gripper on a separate servo controller)
    sets ``rig.tool`` to its :class:`armtree.api.rig.Tool` here; a rig left without one
    gets the arm's own (:class:`armtree.api.rig.ArmTool`). Called before any behaviour
    is set up and before the run starts.
    """


@hookspec(firstresult=True)
def armtree_world_inventory(profile: Profile) -> WorldTruth | None:
    """The nominal world of a profile, for checking the names in a tree's ``expect:``.

    :param profile: the validated profile the tree will run on.
    :return: a :class:`armtree.api.outcomes.truth.WorldTruth` with the world's bodies,
        tag roles and places as the profile describes them (seed 0), or None
        when this plugin does not model the profile's world. The first answer
        that is not None is used; with none, the names of the profile's tag
        roles and places are all that is checked.

    Must not open ports or devices. The built-in simulation answers for its
    profiles.
    """


# ---------------------------------------------------------------------------
# Run options: for plugins that add options to ``run-tree`` (a monitor, a
# file watcher) and act on them before anything is built.
# ---------------------------------------------------------------------------


@hookspec
def armtree_run_options(parser: argparse.ArgumentParser) -> None:
    """Add options to ``run-tree`` and ``armtree run``.

    :param parser: the :class:`argparse.ArgumentParser` of the run command;
        add arguments with ``parser.add_argument``. The parsed values reach
        the run as ``run.settings`` (a dict keyed by each option's ``dest``).

    Use option names of your own (``--monitor``, not ``--port``): a name two
    plugins add is an argparse error.
    """


@hookspec
def armtree_run_opening(run: Run) -> None:
    """A run is about to open its log and build its rig; nothing has moved.

    :param run: the :class:`armtree.runtime.runner.Run`; ``run.settings`` holds the
        command-line options, ``run.control`` its pause/step/stop control.

    The place to start what serves the run (a monitor's server, a file
    watcher) and register its clean-up in ``run.closers``. Raising
    :class:`armtree.ConfigError` refuses the run: the CLI prints it and exits
    2 (a port already in use, say). Unlike the hooks below, any exception
    raised here ends the run before it starts.
    """


# ---------------------------------------------------------------------------
# Run lifecycle: for loggers, monitors and scorers. Called by the runtime on
# its own thread; an exception raised here is reported and the run goes on.
# ---------------------------------------------------------------------------


@hookspec
def armtree_run_started(run: Run) -> None:
    """A run has validated its tree, built its rig and is about to tick.

    :param run: the :class:`armtree.runtime.runner.Run` (tree, rig, clock, log).
    """


@hookspec
def armtree_tick(run: Run) -> None:
    """The tree has just been ticked once; ``run.tick_count`` says which tick.

    Keep it cheap: it is called at the tree's tick rate.
    """


@hookspec
def armtree_run_paused(run: Run, paused: bool) -> None:
    """The run has stopped at a safe point (``paused=True``) or goes on (``False``).

    While paused the run's clock stands still, running behaviours keep their
    resources and the arm has no command under way; nothing is ticked.
    ``run.control.state`` says ``"paused"``; after a step the run pauses
    again at the next safe point.
    """


@hookspec
def armtree_tree_replaced(run: Run, previous: Any) -> None:
    """The run swapped in another tree (``run.replace_tree``, e.g. ``--watch``).

    :param previous: the :class:`armtree.loader.tree.Tree` that was halted; ``run.tree``
        is the new one, set up and about to be ticked; ``run.nodes`` and
        ``run.statuses`` describe it. The clock, rig, log and blackboard go on.
    """


@hookspec
def armtree_interrupt(run: Run, reason: str) -> None:
    """The run is being interrupted (signal, stop key, e-stop, lost link).

    :param reason: a short text such as ``"SIGINT"`` or ``"link lost on /dev/ttyUSB0"``.
        Called before running behaviours are halted.
    """


@hookspec(firstresult=True)
def armtree_ground_truth(run: Run) -> WorldTruth | None:
    """The world as it really is at the end of the run, to judge the tree's ``expect:``.

    :param run: the run, halted, before ``armtree_run_finished``.
    :return: a :class:`armtree.api.outcomes.truth.WorldTruth`, or None when this plugin
        does not know the run's world (real hardware: expectations are then
        reported as not checked). The first answer that is not None is used.

    Never for deciding: behaviours must not call it. The built-in simulation
    lets falling bodies land before it answers.
    """


@hookspec
def armtree_run_finished(run: Run, result: RunResult) -> None:
    """The run has ended and its behaviours are halted; the log is still open.

    :param result: the :class:`armtree.runtime.runner.RunResult` about to be returned.
        A plugin may add lines to the end-of-run summary by setting entries of
        ``result.details`` (``{label: text}``, one short line each, printed as
        ``label: text`` after the summary's own lines, in insertion order); use
        a label of your own, as other plugins add theirs to the same dict.
    """


@hookspec
def armtree_scene_objects(run: Run) -> list[SceneObject] | None:
    """The objects of the run's world, for monitors and recordings to draw.

    :param run: the running :class:`armtree.runtime.runner.Run`.
    :return: :class:`armtree.api.worldview.SceneObject` boxes (the table among
        them, ``kind="table"``), or ``None`` when this plugin knows no world.
        The lists of all plugins are joined.

    This is what people look at, never what a skill decides on: the built-in
    simulation answers with its ground truth. Called from the run's thread at
    most a few times per second; must not block.
    """


# ---------------------------------------------------------------------------
# Sweeps: for plugins that take part in ``armtree sweep`` (a dataset that
# collects every run). Called in the sweep's own process; the runs happen in
# child processes, where the run hooks above are called as for any run.
# ---------------------------------------------------------------------------


@hookspec
def armtree_sweep_options(parser: argparse.ArgumentParser) -> None:
    """Add options to ``armtree sweep``.

    :param parser: the sweep command's :class:`argparse.ArgumentParser`. The parsed
        values reach the sweep's hooks as ``sweep.settings`` (keyed by ``dest``) and
        each run of the sweep as ``run.settings``. Use option names of your own.
    """


@hookspec
def armtree_sweep_started(sweep: Sweep) -> None:
    """A sweep has checked its options and loaded its tree; no run has started.

    :param sweep: the :class:`armtree.cli.sweep.hooks.Sweep` (tree, seeds, out folder,
        settings, preload, closers). What ``sweep.settings`` holds after this hook is
        what every run gets in ``run.settings`` (with the run's ``tree``, ``rig``,
        ``overrides``, ``seed`` and ``sweep_run_dir``, its own folder). Name in
        ``sweep.preload`` the heavy modules every run of yours will import: a local
        sweep imports them once in its run process, before it forks each run.

    Raising :class:`armtree.ConfigError` refuses the sweep: the CLI prints it and
    exits 2, and no run starts. Register clean-up in ``sweep.closers``.
    """


@hookspec
def armtree_sweep_run_finished(sweep: Sweep, outcome: dict[str, Any]) -> None:
    """One run of the sweep has ended, in the sweep's process, in the order runs end.

    :param outcome: what ``sweep.json`` keeps of the run: ``seed``, ``status``,
        ``verdict``, ``reason``, ``run_dir`` (the run's folder), ...

    Keep it short or hand the work to a thread: the sweep starts the next run
    when it returns. An exception is reported and the sweep goes on.
    """


@hookspec
def armtree_sweep_finished(sweep: Sweep, outcomes: list[dict[str, Any]], interrupted: bool) -> None:
    """Every run has ended (``interrupted``: the sweep was stopped before the last).

    Called before the sweep prints its summary and returns; the place to finish
    work still under way. An exception is reported and the sweep goes on.
    """
