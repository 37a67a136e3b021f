from . import gym as gym
from ._advise import (
    BC as BC,
    LWR as LWR,
    AdviseError as AdviseError,
    Critique as Critique,
    Diagnostic as Diagnostic,
    Operators as Operators,
    Provenance as Provenance,
    Session as Session,
    SimEnv as SimEnv,
    Span as Span,
    Why as Why,
    TestResult as TestResult,
    check as check,
    fmt as fmt,
    load_demos as load_demos,
    test as test,
)
from ._advise import advise_demos as advise_demos, advise_lerobot as advise_lerobot, load_lerobot as load_lerobot
from .lerobot import to_arrow as to_arrow
from .gym import make_env as make_env
from ._advise import study as study
from . import studies as studies

__all__: list[str]
