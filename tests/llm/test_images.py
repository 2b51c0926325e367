"""Images in the model layer: each provider's wire format (seen by the loopback ``fault_server``),
image hashes in the cache key, replay, PNG checks, the text-only offline model's refusal, and
text-only calls exactly as they were before images existed."""

from __future__ import annotations

import base64
import struct
import zlib
from pathlib import Path

import pytest
from fault_server import FaultServer, answer
from pydantic import BaseModel, ConfigDict

from regen.core.base import Answer
from regen.errors import CacheMissError, ConfigError
from regen.llm import LLM
from regen.llm.base import Message, Sampling, image_message
from regen.llm.cache import CallCache, cache_key
from regen.llm.providers.anthropic import AnthropicProvider
from regen.llm.providers.local import LocalProvider
from regen.llm.providers.openai_compat import OpenAIProvider
from regen.llm.testing import QueuedProvider

UNREACHABLE = "http://127.0.0.1:9/v1"  # nothing listens: a call that reaches for it fails


class Causes(Answer):
    causes: list[str]


def png(gray: int) -> bytes:
    """A valid 1x1 grayscale PNG of brightness ``gray`` (0-255)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", 1, 1, 8, 0, 0, 0, 0)  # 1x1, 8 bit, grayscale
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(bytes([0, gray]))) + chunk(b"IEND", b""))


DARK, LIGHT = png(10), png(240)
JPEG = b"\xff\xd8\xff\xe0\x00\x10JFIF\x00" + b"\x00" * 32


def _b64(data: bytes) -> str:
    return base64.b64encode(data).decode("ascii")


def _openai(url: str, **kw) -> OpenAIProvider:
    return OpenAIProvider("vision-model", base_url=url, api_key="sk-img-secret", base_delay=0.01, **kw)


def _anthropic(url: str) -> AnthropicProvider:
    return AnthropicProvider("claude-test", base_url=url, api_key="k", base_delay=0.01)


# --- wire formats ----------------------------------------------------------------------------


def test_openai_body_holds_the_text_part_then_the_image_as_a_png_data_url(fault_server: FaultServer) -> None:
    fault_server.queue(answer('{"causes": ["a dark frame"]}'))
    llm = LLM(_openai(fault_server.openai_url))
    got = llm.structured([image_message("what stops the car?", [DARK])], Causes, system="be brief")
    assert got.causes == ["a dark frame"]
    sent = fault_server.requests[0].body["messages"]
    assert sent[0] == {"role": "system", "content": "be brief"}
    assert sent[1] == {"role": "user", "content": [
        {"type": "text", "text": "what stops the car?"},
        {"type": "image_url", "image_url": {"url": "data:image/png;base64," + _b64(DARK)}}]}
    url = sent[1]["content"][1]["image_url"]["url"]
    assert base64.b64decode(url.partition(",")[2]) == DARK


def test_openai_prompt_schema_mode_keeps_the_image_parts(fault_server: FaultServer) -> None:
    fault_server.queue(answer('{"causes": ["a"]}'))
    LLM(_openai(fault_server.openai_url, schema_mode="json_object")).structured(
        [image_message("q", [DARK, LIGHT])], Causes)
    sent = fault_server.requests[0].body["messages"]
    assert sent[0]["role"] == "system" and "JSON schema" in sent[0]["content"]
    assert [p["type"] for p in sent[1]["content"]] == ["text", "image_url", "image_url"]
    assert sent[1]["content"][2]["image_url"]["url"].endswith(_b64(LIGHT))


def test_anthropic_body_holds_the_image_block_before_the_text(fault_server: FaultServer) -> None:
    fault_server.queue(answer('{"causes": ["glare"]}'))
    got = LLM(_anthropic(fault_server.anthropic_url)).structured(
        [image_message("what stops the car?", [LIGHT])], Causes, system="be brief")
    assert got.causes == ["glare"]
    body = fault_server.requests[0].body
    assert body["system"] == "be brief"
    assert body["messages"] == [{"role": "user", "content": [
        {"type": "image", "source": {"type": "base64", "media_type": "image/png", "data": _b64(LIGHT)}},
        {"type": "text", "text": "what stops the car?"}]}]


def test_both_http_providers_accept_images_and_the_offline_model_does_not() -> None:
    assert _openai(UNREACHABLE).accepts_images is True
    assert _anthropic(UNREACHABLE).accepts_images is True
    assert LocalProvider().accepts_images is False  # no model file is touched by the constructor
    assert QueuedProvider().accepts_images is False  # the default of a provider that never said


# --- text-only calls are as they were --------------------------------------------------------

# recorded from the providers before images existed (the same messages, schema and sampling)
OPENAI_TEXT_BODY = (
    '{"model":"m","messages":[{"role":"system","content":"be brief"},{"role":"user","content":'
    '"why does the car stop? \u00e9"}],"temperature":0.0,"max_tokens":1024,"seed":0,"response_format":'
    '{"type":"json_schema","json_schema":{"name":"Causes","schema":{"properties":{"causes":{"items":'
    '{"type":"string"},"title":"Causes","type":"array"}},"required":["causes"],"title":"Causes",'
    '"type":"object"}}}}')
ANTHROPIC_TEXT_BODY = (
    '{"model":"c","max_tokens":1024,"temperature":0.0,"messages":[{"role":"user","content":'
    '"why does the car stop? \u00e9"}],"system":"be brief","tools":[{"name":"answer","description":'
    '"Give the answer.","input_schema":{"properties":{"causes":{"items":{"type":"string"},"title":'
    '"Causes","type":"array"}},"required":["causes"],"title":"Causes","type":"object"}}],'
    '"tool_choice":{"type":"tool","name":"answer"}}')


class Recorded(BaseModel):  # the model the bodies above were recorded with
    model_config = ConfigDict(title="Causes")

    causes: list[str]

TEXT_KEY = "b3d1c72663e02a1207e47b3892c3f3c94b035ba76c5244e169a7a35723a805a3"


@pytest.mark.parametrize("empty_images", [False, True], ids=["no field", "empty list"])
def test_text_only_request_bodies_are_byte_identical(fault_server: FaultServer, empty_images: bool) -> None:
    user: Message = {"role": "user", "content": "why does the car stop? \u00e9"}
    if empty_images:
        user["images"] = []
    msgs: list[Message] = [{"role": "system", "content": "be brief"}, user]
    fault_server.queue(answer('{"causes": ["a"]}'), answer('{"causes": ["a"]}'))
    LLM(OpenAIProvider("m", base_url=fault_server.openai_url, api_key="k")).structured(msgs, Recorded)
    LLM(AnthropicProvider("c", base_url=fault_server.anthropic_url, api_key="k")).structured(msgs, Recorded)
    assert fault_server.requests[0].raw.decode() == OPENAI_TEXT_BODY
    assert fault_server.requests[1].raw.decode() == ANTHROPIC_TEXT_BODY


def test_text_only_cache_key_is_the_one_recorded_before_images() -> None:
    msgs: list[Message] = [{"role": "system", "content": "be brief"}, {"role": "user", "content": "why? \u00e9"}]
    assert cache_key("openai:m", msgs, {"type": "object"}, Sampling()) == TEXT_KEY
    msgs[1]["images"] = []
    assert cache_key("openai:m", msgs, {"type": "object"}, Sampling()) == TEXT_KEY


# --- cache keys and replay -------------------------------------------------------------------


def _key(*images: bytes, text: str = "what stops the car?") -> str:
    return cache_key("openai:vision-model", [image_message(text, list(images))], None, Sampling())


def test_cache_key_differs_for_a_different_image_and_is_equal_for_the_same() -> None:
    assert _key(DARK) == _key(bytes(bytearray(DARK)))  # the same bytes, another object
    assert _key(DARK) != _key(LIGHT)
    assert _key(DARK, LIGHT) != _key(LIGHT, DARK)  # order is part of what the model is shown
    assert _key(DARK) != _key(DARK, DARK)
    assert _key(DARK) != cache_key("openai:vision-model",
                                   [{"role": "user", "content": "what stops the car?"}], None, Sampling())


def test_an_image_call_replays_from_the_cache_without_a_server(fault_server: FaultServer,
                                                                tmp_path: Path) -> None:
    cache = tmp_path / "llm.sqlite"
    fault_server.queue(answer('{"causes": ["a dark frame"]}'))
    first = LLM(_openai(fault_server.openai_url), cache=cache).ask([image_message("q", [DARK])], Causes)
    assert not first.cached and len(fault_server.requests) == 1
    fault_server.close()

    for replay in (True, False):  # a replay, and a run that may call but finds the answer
        llm = LLM(_openai(UNREACHABLE, attempts=1), cache=cache, replay=replay)
        again = llm.ask([image_message("q", [bytes(DARK)])], Causes)
        assert again.cached and again.value.causes == ["a dark frame"] and again.call_id == first.call_id
        assert llm.stats.total.model_calls == 0
    with pytest.raises(CacheMissError):  # another image is another call
        LLM(_openai(UNREACHABLE), cache=cache, replay=True).ask([image_message("q", [LIGHT])], Causes)


def test_the_cache_file_holds_neither_the_image_nor_the_key(fault_server: FaultServer, tmp_path: Path) -> None:
    cache = tmp_path / "llm.sqlite"
    fault_server.queue(answer('{"causes": ["a"]}'))
    LLM(_openai(fault_server.openai_url), cache=CallCache(cache)).ask([image_message("q", [DARK])], Causes)
    CallCache(cache).export_json(tmp_path / "cassette.json")
    for f in tmp_path.iterdir():
        data = f.read_bytes()
        for secret in (DARK[8:], _b64(DARK).encode(), b"sk-img-secret"):
            assert secret not in data, f.name


# --- refusals --------------------------------------------------------------------------------


def test_image_message_refuses_bytes_that_are_not_a_png() -> None:
    with pytest.raises(ConfigError, match="image 2 of a message is not a PNG file"):
        image_message("q", [DARK, JPEG])
    with pytest.raises(ConfigError, match="not the bytes of a PNG file"):
        image_message("q", ["frame.png"])  # type: ignore[list-item]
    with pytest.raises(ConfigError, match="put one in a list"):
        image_message("q", DARK)


@pytest.mark.parametrize("which", ["openai", "anthropic"])
def test_a_non_png_is_refused_before_any_request(fault_server: FaultServer, which: str) -> None:
    def make() -> OpenAIProvider | AnthropicProvider:
        return (_openai(fault_server.openai_url) if which == "openai"
                else _anthropic(fault_server.anthropic_url))

    msg: Message = {"role": "user", "content": "q", "images": [JPEG]}
    with pytest.raises(ConfigError, match="image 1 of a message is not a PNG file"):
        LLM(make()).ask([msg], Causes)
    with pytest.raises(ConfigError, match="not a PNG file"):  # a provider used without LLM
        make().complete([msg], schema=None, sampling=Sampling())
    assert fault_server.requests == []


def test_images_on_a_system_message_are_refused(fault_server: FaultServer) -> None:
    msg: Message = {"role": "system", "content": "q", "images": [DARK]}
    with pytest.raises(ConfigError, match="only user messages may"):
        LLM(_openai(fault_server.openai_url)).ask([msg, {"role": "user", "content": "q"}], Causes)
    assert fault_server.requests == []


def _no_model(self) -> None:
    raise AssertionError("the model was loaded for a call it must refuse")


@pytest.mark.parametrize("replay", [False, True])
def test_the_offline_model_refuses_images_before_loading_or_looking_up(
        monkeypatch: pytest.MonkeyPatch, replay: bool) -> None:
    monkeypatch.setattr(LocalProvider, "llama", _no_model)
    llm = LLM(LocalProvider(), replay=replay)
    with pytest.raises(ConfigError, match="the offline model reads text only; use --text-only or an "
                                          "image-capable provider"):
        llm.ask([image_message("what stops the car?", [DARK])], Causes)
    with pytest.raises(ConfigError, match="the offline model reads text only"):
        llm.weigh([image_message("q", [DARK])], ("yes", "no"), prefix='{"answer": "')


def test_the_offline_provider_refuses_images_when_called_directly(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(LocalProvider, "llama", _no_model)
    prov, msgs = LocalProvider(), [image_message("q", [DARK])]
    with pytest.raises(ConfigError, match="the offline model reads text only"):
        prov.complete(msgs, schema=None, sampling=Sampling())
    with pytest.raises(ConfigError, match="the offline model reads text only"):
        prov.option_probs(msgs, prefix="", options=("yes", "no"))


def test_a_provider_that_never_said_it_reads_images_is_not_sent_them() -> None:
    prov = QueuedProvider(['{"causes": ["a"]}'])
    with pytest.raises(ConfigError, match="queued:test reads text only and this call carries 2 image"):
        LLM(prov).ask([image_message("q", [DARK, LIGHT])], Causes)
    assert prov.requests == []
    assert LLM(prov).ask("q", Causes).value.causes == ["a"]  # text still goes through
