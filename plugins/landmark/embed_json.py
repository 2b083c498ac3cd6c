"""Writes a C++ header holding a JSON file as a string constant."""
import sys

src, dst, name = sys.argv[1:4]
with open(src, encoding="utf-8") as f:
    text = f.read()
if ')json"' in text:
    sys.exit(f"{src}: contains the raw-string delimiter")
with open(dst, "w", encoding="utf-8") as f:
    f.write(f"/* generated from {src.split('/')[-1]}; do not edit */\n")
    f.write("#pragma once\n")
    f.write(f'static const char {name}[] = R"json({text})json";\n')
