"""A real call to the offline default model (deselect with -m 'not model'; CI runs it)."""

from __future__ import annotations

import pytest

from regen.core.base import Answer

pytestmark = [pytest.mark.model, pytest.mark.usefixtures("shared_cache")]


class Causes(Answer):
    causes: list[str]


def test_offline_model_returns_a_schema_valid_answer() -> None:
    pytest.importorskip("llama_cpp", reason="the 'local' extra is not installed")
    from regen.llm import LLM

    llm = LLM("local")
    got = llm.ask("List two plausible causes why a car driving forward on a road stops abruptly. "
                  'Answer as JSON: {"causes": ["...", "..."]}', Causes, purpose="smoke")
    assert isinstance(got.value, Causes)
    assert len(got.value.causes) >= 1 and all(c.strip() for c in got.value.causes)
    assert llm.stats.total.output_tokens > 0


def test_offline_model_weighs_an_obvious_yes_above_an_obvious_no(tmp_path) -> None:
    pytest.importorskip("llama_cpp", reason="the 'local' extra is not installed")
    from regen.llm import LLM

    llm = LLM("local", cache=tmp_path / "c.sqlite")
    assert llm.can_weigh
    q = 'Is {} a reason for a car to brake hard? Answer as JSON: {{"answer": "yes" or "no"}}'
    yes = llm.weigh(q.format("a child running onto the road in front of it"), ("yes", "no"),
                    prefix='{"answer": "', purpose="smoke")
    no = llm.weigh(q.format("a song playing on a radio in another country"), ("yes", "no"),
                   prefix='{"answer": "', purpose="smoke")
    assert sum(yes.value.values()) == pytest.approx(1.0) and not yes.cached
    assert yes.value["yes"] > no.value["yes"] + 0.1
    again = LLM("local", cache=tmp_path / "c.sqlite", replay=True)  # replayed from the cache file
    assert again.weigh(q.format("a child running onto the road in front of it"), ("yes", "no"),
                       prefix='{"answer": "', purpose="smoke").value == yes.value


def test_a_process_that_loaded_the_model_exits_without_a_traceback() -> None:
    """llama-cpp's own finalizer ran after the interpreter had torn its bindings down and printed
    a TypeError at the end of every command that loaded the model."""
    import subprocess
    import sys

    pytest.importorskip("llama_cpp", reason="the 'local' extra is not installed")
    code = "from regen.llm import LLM; LLM('local').provider.llama()"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr and "TypeError" not in proc.stderr, proc.stderr


def test_other_threads_keep_their_output_while_the_model_loads() -> None:
    """llama-cpp-python pointed the process's stdout and stderr at /dev/null while it loaded the
    model: a batch lost the progress lines other behaviors printed in that second. A thread
    numbers its lines on stderr while the model loads; every number arrives, and llama.cpp's own
    load messages do not."""
    import subprocess
    import sys

    pytest.importorskip("llama_cpp", reason="the 'local' extra is not installed")
    code = ("import sys, threading, time\n"
            "from regen.llm import LLM\n"
            "stop = []\n"
            "def tick():\n"
            "    i = 0\n"
            "    while not stop:\n"
            "        print(f'tick {i}', file=sys.stderr, flush=True); i += 1; time.sleep(0.01)\n"
            "t = threading.Thread(target=tick); t.start()\n"
            "try:\n"
            "    LLM('local').provider.llama()\n"
            "finally:  # a failed load fails the test instead of leaving the thread ticking\n"
            "    stop.append(1); t.join()\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    ticks = [int(line.split()[1]) for line in proc.stderr.splitlines() if line.startswith("tick ")]
    assert len(ticks) > 20 and ticks == list(range(len(ticks))), proc.stderr[-2000:]
    assert not [line for line in proc.stderr.splitlines() if not line.startswith("tick ")], proc.stderr[-2000:]


def test_the_grammar_first_sampler_writes_what_llama_cpps_own_chain_writes(monkeypatch) -> None:
    # the local provider checks the grammar on the best token first; at temperature 0 the answer
    # must be the one llama-cpp-python's sampler chain (grammar over the whole vocabulary) gives,
    # also where the grammar refuses the model's favourite (an enum it would not write)
    pytest.importorskip("llama_cpp", reason="the 'local' extra is not installed")
    import llama_cpp

    from regen.llm.providers.local import LocalProvider
    from regen.llm.providers.local_sampler import GrammarFirstGreedy

    llm = LocalProvider().llama()
    refusals = []
    apply = GrammarFirstGreedy._apply
    monkeypatch.setattr(GrammarFirstGreedy, "_apply",
                        lambda self, data, size: (refusals.append(size) if size > 1 else None,
                                                  apply(self, data, size))[1])
    asks = [
        ("Name two causes why a car brakes hard. Answer as JSON.",
         {"type": "object", "properties": {"causes": {"type": "array", "items": {"type": "string"}}},
          "required": ["causes"]}),
        ('Is the sky blue on a clear day? Answer as JSON: {"answer": "..."}',
         {"type": "object", "properties": {"answer": {"type": "string", "enum": ["zebra crossing", "maybe"]}},
          "required": ["answer"]}),
    ]

    def answers() -> list[str]:
        out = []
        for text, schema in asks:
            llm.reset()
            got = llm.create_chat_completion(messages=[{"role": "user", "content": text}], temperature=0.0,
                                             max_tokens=64, seed=0,
                                             response_format={"type": "json_object", "schema": schema})
            out.append(got["choices"][0]["message"]["content"])
        return out

    ours = answers()
    assert refusals, "the enum the model would not write must take the whole-vocabulary path"
    monkeypatch.setattr(type(llm), "_init_sampler", llama_cpp.Llama._init_sampler)
    assert answers() == ours
    assert '"zebra crossing"' in ours[1] or '"maybe"' in ours[1]
