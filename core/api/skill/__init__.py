"""The base of skills: behaviours whose work is a generator of non-blocking actions.

A :class:`~armtree.api.skill.base.Skill` yields
:class:`~armtree.api.skill.actions.Action` objects (move, home, grip, pause, look)
that :class:`~armtree.api.skill.base.Process` starts and polls one tick at a time;
:class:`~armtree.api.skill.arm.ArmSkill` adds the motion parameters and where to
put the camera over a point; the rig's :class:`~armtree.api.skill.eye.Eye` reads
each camera frame once for every behaviour of a run; ``reach``, ``sightline`` and
``survey`` answer what the arm reaches, what its links hide from a fixed camera,
and where a survey looks. The built-in skills (plugins/skills/) and the calibration
trees (plugins/calibration/) are built on it; so can a plugin's own skills.
"""
