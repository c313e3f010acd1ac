# The public names of armtree for type checkers; __init__.py looks them up on first use.
from armtree.api.behaviour import Behaviour as Behaviour
from armtree.api.skill.actions import Action as Action
from armtree.api.skill.actions import SkillFailure as SkillFailure
from armtree.api.skill.arm import ArmSkill as ArmSkill
from armtree.api.skill.base import Skill as Skill
from armtree.config.params import REQUIRED as REQUIRED
from armtree.config.params import Binding as Binding
from armtree.config.params import Param as Param
from armtree.config.params import ParamKind as ParamKind
from armtree.config.params import Place as Place
from armtree.config.params import Position as Position
from armtree.config.params import TagRole as TagRole
from armtree.errors import ConfigError as ConfigError
from armtree.errors import HardwareFault as HardwareFault
from armtree.errors import PlanningError as PlanningError
from armtree.errors import Unreachable as Unreachable
from armtree.hooks.hookspecs import hookimpl as hookimpl
from armtree.hooks.hookspecs import hookspec as hookspec
from armtree.loader.profile import Profile as Profile
from armtree.loader.profile import load_profile as load_profile
from armtree.loader.tree import Tree as Tree
from armtree.loader.tree_loader import load_tree as load_tree
from armtree.runtime.run_end import RunResult as RunResult
from armtree.runtime.runner import Run as Run
from armtree.runtime.runner import run as run

__version__: str
__all__: list[str]
