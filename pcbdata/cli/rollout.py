"""`pcbdata rollout`: run an agent in the routing environment over a board set."""
from __future__ import annotations

import os
import sys

from pcbdata.cli import _executor_options

VERB = "rollout"
HELP = ("route a board set with an agent (scripted, scripted-shove, negotiated, d1, random, llm, "
        "llm-plan, llm-direct, llm-paper, llm-paper-plan, llm-paper-direct, module:Class)")
#: The language-model options: flag -> (option name of pcbdata.agents.llm_client, type).
LLM_FLAGS = {"--base-url": ("base_url", str), "--model": ("model", str),
             "--api-key-env": ("api_key_env", str), "--temperature": ("temperature", float),
             "--llm-seed": ("seed", int), "--max-tokens": ("max_tokens", int),
             "--request-timeout": ("timeout_s", float), "--max-retries": ("max_retries", int),
             "--retry-backoff": ("backoff_s", float),
             "--retry-backoff-cap": ("backoff_cap_s", float)}
METAVARS = {"--base-url": "URL", "--model": "NAME", "--api-key-env": "VAR",
            "--request-timeout": "SECONDS", "--retry-backoff": "SECONDS",
            "--retry-backoff-cap": "SECONDS"}
LLM_HELP = {
    "--base-url": "an OpenAI-compatible server, e.g. http://127.0.0.1:8000/v1 (vLLM), "
                  "http://127.0.0.1:8080/v1 (llama-server), http://127.0.0.1:11434/v1 (Ollama)",
    "--model": "the model name the server knows",
    "--api-key-env": "environment variable holding the API key (default: OPENAI_API_KEY; "
                     "unset: no key is sent); the key is never written into the run",
    "--temperature": "sampling temperature (default: 0)",
    "--llm-seed": "sampling seed offset: rollout k sends seed N + k (default: 0)",
    "--max-tokens": "completion token limit per request (default: 512 for llm, 8192 for "
                    "llm-plan, 16384 for llm-direct; llm-paper 256, the paper's cap for a model "
                    "with hidden reasoning: give 512 for one without; llm-paper-plan 8192, "
                    "llm-paper-direct 16384)",
    "--request-timeout": "seconds per request (default: 120)",
    "--max-retries": "retries of a request after a connection error, time-out, HTTP 429 or "
                     "5xx or a malformed answer (default: 4)",
    "--retry-backoff": "first retry's wait in seconds, doubled each retry (default: 1)",
    "--retry-backoff-cap": "longest wait between retries in seconds (default: 30)"}


def register(parser) -> None:
    parser.add_argument("dir", metavar="SET", help="a built board set")
    parser.add_argument("--config", required=True,
                        help="any config the set holds, e.g. d2, d1-g10-random-walk, "
                             "d2-hard-custom-<hash>, d3-a (read from its manifest)")
    parser.add_argument("--split", default="test", help="split name (default: test)")
    parser.add_argument("--agent", default="scripted",
                        help="scripted (default), scripted-shove (push_n_shove when walkaround "
                             "fails), d1 (D1 boards: lattice plan with rip-up and reroute), "
                             "random, llm (a language model, one request per step), llm-plan "
                             "(one request: the whole action sequence), llm-direct (one "
                             "request: the copper as .kicad_pcb items), llm-paper, "
                             "llm-paper-plan, llm-paper-direct (the same three in the paper's "
                             "protocol: free coordinates, <think>/<action> replies), "
                             "policy (the shipped "
                             "learned router; policy:CHECKPOINT for another, docs/learn.md), "
                             "negotiated (plans every connection at once with rip-up and "
                             "reroute, then lays the plan), or module:Class with act(obs, info)")
    parser.add_argument("--rollouts", type=int, default=1, help="rollouts per board (seeds 0..)")
    parser.add_argument("--out", required=True, metavar="RUNS",
                        help="RUNS/<board_id>/<rollout>.kicad_pcb + .json (pcbdata eval reads it)")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                        help="parallel environments, each with its KiCad worker (default: cores; "
                             "--executor ray uses every CPU of the cluster)")
    parser.add_argument("--limit", type=int, help="only the first N boards")
    parser.add_argument("--max-steps", type=int,
                        help="step limit (default: per board, max(200, 8 x the connections "
                             "left at reset))")
    parser.add_argument("--drc", choices=("step", "terminal"), default="step",
                        help="KiCad DRC after every copper change (default) or at the end only")
    parser.add_argument("--rollout-timeout", type=float, default=None, metavar="SECONDS",
                        help="wall-time limit of one rollout in its worker (default: 3600; a "
                             "slow language model may need more: the rollout is otherwise "
                             "reported failed and left pending)")
    group = parser.add_argument_group("language models (--agent llm, llm-plan, llm-direct, "
                                      "llm-paper, llm-paper-plan, llm-paper-direct; "
                                      "docs/env_llm.md)")
    for flag, (dest, kind) in LLM_FLAGS.items():
        group.add_argument(flag, dest=f"llm_{dest}", type=kind, help=LLM_HELP[flag],
                           metavar=METAVARS.get(flag, {int: "N", float: "X"}.get(kind, "TEXT")))
    group.add_argument("--llm-option", dest="llm_protocol", action="append", default=[],
                       metavar="NAME=VALUE",
                       help="a protocol option of the paper's agents (llm-paper, "
                            "llm-paper-plan, llm-paper-direct), repeatable: turns=200, "
                            "history=2, no_effect=routing|all, require_think=true, "
                            "chat_history=false, system_tokens=auto|tokenize|request|off, "
                            "plan_failure=skip_net|continue, plan_max_steps=N, "
                            "board_first=false, direct_repair=false, extra_body={...} "
                            "(docs/env_llm.md)")
    _executor_options.add(parser)
    parser.set_defaults(run=run)


def llm_options(args) -> dict | None:
    """The language-model options given (None for another agent without them)."""
    from pcbdata.core.errors import UserError

    given = {dest: getattr(args, f"llm_{dest}") for dest, _ in LLM_FLAGS.values()
             if getattr(args, f"llm_{dest}") is not None}
    protocol = [_name_value(text) for text in getattr(args, "llm_protocol", None) or []]
    if protocol and not args.agent.startswith("llm-paper"):
        raise UserError("--llm-option is for the paper's agents (llm-paper, llm-paper-plan, "
                        "llm-paper-direct)")
    given.update(protocol)
    if not args.agent.startswith("llm") and not given:
        return None
    env_name = given.get("api_key_env")
    if env_name is not None and not os.environ.get(env_name):
        raise UserError(f"--api-key-env {env_name}: that environment variable is not set")
    return given


def _name_value(text: str) -> tuple[str, object]:
    """NAME=VALUE with VALUE read as JSON when it is (true, 2, null), else as text."""
    import json

    from pcbdata.core.errors import UserError

    name, sep, value = text.partition("=")
    if not sep or not name.strip():
        raise UserError(f"--llm-option {text!r}: use NAME=VALUE")
    try:
        return name.strip(), json.loads(value)
    except ValueError:
        return name.strip(), value


def run(args) -> int:
    from pcbdata.core.errors import UserError
    from pcbdata.runners.rollout import ROLLOUT_TIMEOUT, run_rollouts

    if args.rollouts < 1 or args.workers < 1:
        raise UserError("--rollouts and --workers must be at least 1")
    timeout = ROLLOUT_TIMEOUT if args.rollout_timeout is None else args.rollout_timeout
    if not timeout > 0:
        raise UserError("--rollout-timeout must be more than 0 seconds")
    summary = run_rollouts(args.dir, args.config, args.split, args.agent, args.rollouts,
                           args.out, args.workers, args.limit,
                           {"max_steps": args.max_steps, "drc": args.drc},
                           timeout=timeout, executor=_executor_options.executor(args),
                           agent_options=llm_options(args))
    mean = summary["mean_reward"]
    shown = "n/a" if mean is None else f"{mean:.3f}"
    print(f"done: {summary['run']} rollouts run, {summary['skipped']} already done, "
          f"{summary['terminated']} fully connected, {summary['engine_failures']} engine "
          f"failures, mean reward {shown}" if summary["run"] else
          f"done: nothing to run ({summary['skipped']} already done)", end="")
    print(f", {summary['seconds']:.1f} s")
    if summary["failed"]:
        print(f"pcbdata: KiCad failed: {summary['failed']} rollouts failed (time limit or crash; "
              f"see above); run again to retry them", file=sys.stderr)
        return 3
    return 0
