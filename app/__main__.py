import sys

try:
    from app.cli import main
except KeyboardInterrupt:  # Ctrl-C before the command line is even read: still one line, exit 130
    print("brdf-studio: interrupted", file=sys.stderr)
    sys.exit(130)

sys.exit(main())
