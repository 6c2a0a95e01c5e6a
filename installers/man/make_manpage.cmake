# Writes a man page from a hand-written roff template and the program's own --help texts,
# so that options and subcommands in the man page are those of the binary being packaged.
#   cmake -DPROGRAM=<binary> -DNAME=<name> -DTEMPLATE=<x.1.in> -DOUTPUT=<x.1.gz>
#         -DVERSION=<v> [-DSUBCOMMANDS=ON] -P make_manpage.cmake
# With SUBCOMMANDS, @COMMANDS@ receives one section per command listed under "commands:" in
# `PROGRAM --help`; otherwise @OPTIONS@ receives `PROGRAM --help`.

# Current policies: under the old CMP0053, "@VERSION@" in quoted text would be expanded.
cmake_minimum_required(VERSION 3.25)

# Help text as a roff no-fill block: backslashes escaped, control characters at line
# starts neutralized, the binary's path replaced by its name.
function(help_block out)
  execute_process(COMMAND ${PROGRAM} ${ARGN} OUTPUT_VARIABLE text RESULT_VARIABLE status)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "${PROGRAM} ${ARGN} exited with ${status}")
  endif()
  string(REPLACE "${PROGRAM}" "${NAME}" text "${text}")
  if(NOT text MATCHES "\n$")
    string(APPEND text "\n")
  endif()
  string(REPLACE "\\" "\\e" text "${text}")
  string(REGEX REPLACE "(^|\n)([.'])" "\\1\\\\&\\2" text "${text}")
  set(${out} ".nf\n${text}.fi\n" PARENT_SCOPE)
endfunction()

file(READ ${TEMPLATE} page)
string(REPLACE "@VERSION@" "${VERSION}" page "${page}")
if(SUBCOMMANDS)
  execute_process(COMMAND ${PROGRAM} --help OUTPUT_VARIABLE usage RESULT_VARIABLE status)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "${PROGRAM} --help exited with ${status}")
  endif()
  string(REGEX REPLACE ".*\ncommands:\n" "" listing "${usage}")
  string(REGEX MATCHALL "(^|\n)  [a-z][a-z-]*" names "${listing}")
  if(NOT names)
    message(FATAL_ERROR "no commands found in `${PROGRAM} --help`")
  endif()
  set(commands "")
  foreach(name ${names})
    string(STRIP "${name}" name)
    help_block(block ${name} --help)
    string(APPEND commands ".SS ${name}\n${block}")
  endforeach()
  string(REPLACE "@COMMANDS@" "${commands}" page "${page}")
else()
  help_block(block --help)
  string(REPLACE "@OPTIONS@" "${block}" page "${page}")
endif()

string(REGEX REPLACE "\\.gz$" "" plain "${OUTPUT}")
file(WRITE ${plain} "${page}")
# gzip -n: no name or time stamp inside, so the package builds reproducibly.
execute_process(COMMAND gzip -9nf ${plain} RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "gzip ${plain} failed")
endif()
