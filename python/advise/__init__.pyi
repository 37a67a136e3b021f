from . import gym as gym
from ._advise import (
    BC as BC,
    LWR as LWR,
    AdviseError as AdviseError,
    Diagnostic as Diagnostic,
    Operators as Operators,
    Session as Session,
    SimEnv as SimEnv,
    Span as Span,
    TestResult as TestResult,
    check as check,
    fmt as fmt,
    load_demos as load_demos,
    test as test,
)

__all__: list[str]
