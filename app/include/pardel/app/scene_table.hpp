/**
 * @file scene_table.hpp
 * The scene reader's entry point for a scene built in memory as a toml::table (the Python module
 * builds one from pardel.solve's keyword arguments): the checks and messages of parse_scene without
 * writing and parsing TOML text. Apart from scene.hpp because it needs toml++'s headers.
 */
#ifndef PARDEL_APP_SCENE_TABLE_HPP
#define PARDEL_APP_SCENE_TABLE_HPP

#include <string>
#include <vector>

#ifndef TOML_EXCEPTIONS
#define TOML_EXCEPTIONS 1
#endif
#include <toml++/toml.h>

#include "pardel/app/scene.hpp"

namespace pardel::app {

/**
 * Reads and checks a scene given as a TOML table, as parse_scene reads a parsed file: the same
 * keys, checks and SceneError messages. `source_name` names the scene in messages and relative
 * paths inside it resolve against its folder; a value without a source position (one built in
 * memory) is located as "SOURCE_NAME: error: ...".
 */
Scene read_scene_table(const toml::table& root, const std::string& source_name, const ModelResolver& resolve,
                       const std::vector<std::string>& model_names = {});

}  // namespace pardel::app

#endif  // PARDEL_APP_SCENE_TABLE_HPP
