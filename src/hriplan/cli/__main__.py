from hriplan.cli.main import app

app(prog_name="hriplan")
