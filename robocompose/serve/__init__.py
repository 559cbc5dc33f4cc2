"""The composition service: trained EG-GAN generators kept warm behind HTTP, and a page to ask them.

    robocompose serve [--host 127.0.0.1] [--port 8000] [--modular-model NAME=PATH] [--teams-model NAME=PATH]

`app.create_app` answers with the same query functions as `robocompose compose` (modular.compose.ModularComposer,
teams.compose.TeamsComposer); `page.html` is the page served at `/`. Nothing below this package imports it.
"""
