"""Built-in providers: OpenAI(-compatible), Anthropic, and the in-process local model."""
