"""URScript message built-ins: log text and operator popups, published on the primary interface."""
from sim_ursim.messages import PopupMessage, TextMessage
from sim_ursim.urscript.builtins.registry import builtin
from sim_ursim.urscript.script_thread import ThreadContext
from sim_ursim.urscript.values import to_str


@builtin
def textmsg(ctx: ThreadContext, s1, s2=""):
    """Log message: the texts of s1 and s2 concatenated (primary interface text message)."""
    ctx.publish(TextMessage(text=to_str(s1) + to_str(s2)))


@builtin
def popup(ctx: ThreadContext, s, title="Popup", warning=False, error=False, blocking=False):
    """Popup message to the operator (never blocks here: there is no operator to close it)."""
    ctx.publish(PopupMessage(title=to_str(title), text=to_str(s), warning=bool(warning), error=bool(error)))
