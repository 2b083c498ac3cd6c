/* The one element pattern (docs/hacking.md): every element keeps what the
 * user sets in a Settings struct, declares its properties once in a
 * PropertyTable (name, text, range and the Settings field; the default is
 * the field's initial value), holds the Settings in a SharedSettings (lock
 * and generation counter) and turns them into a checked Config with one
 * parse function, used at start (a bad value is an error) and while
 * playing (a bad value is a warning and the previous Config stays: a robot
 * must not stop because a slider went wrong). */
#pragma once

#include <gst/base/gstbasetransform.h>
#include <gst/gst.h>
#include <gst/video/video.h>

#include <exception>

#include <functional>
#include <mutex>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "elementframes.h"
#include "frameformat.h"
#include "landmarkmeta.h"

namespace landmark {

/* The GParamSpec and GValue access of the number types properties have. */
template <typename T>
GParamSpec *
number_param_spec (const char *name, const char *nick, const char *blurb,
    T min, T max, T def, GParamFlags f)
{
  if constexpr (std::is_same<T, gdouble>::value)
    return g_param_spec_double (name, nick, blurb, min, max, def, f);
  else if constexpr (std::is_same<T, gint>::value)
    return g_param_spec_int (name, nick, blurb, min, max, def, f);
  else if constexpr (std::is_same<T, guint>::value)
    return g_param_spec_uint (name, nick, blurb, min, max, def, f);
  else {
    static_assert (std::is_same<T, guint64>::value, "not a number property");
    return g_param_spec_uint64 (name, nick, blurb, min, max, def, f);
  }
}

inline void value_get_number (const GValue *v, gdouble *x) { *x = g_value_get_double (v); }
inline void value_get_number (const GValue *v, gint *x) { *x = g_value_get_int (v); }
inline void value_get_number (const GValue *v, guint *x) { *x = g_value_get_uint (v); }
inline void value_get_number (const GValue *v, guint64 *x) { *x = g_value_get_uint64 (v); }
inline void value_set_number (GValue *v, gdouble x) { g_value_set_double (v, x); }
inline void value_set_number (GValue *v, gint x) { g_value_set_int (v, x); }
inline void value_set_number (GValue *v, guint x) { g_value_set_uint (v, x); }
inline void value_set_number (GValue *v, guint64 x) { g_value_set_uint64 (v, x); }

/* The properties of one Settings struct, installed with ids 1, 2, ... in
 * the order they are added. Built once, in class_init. */
template <typename Settings> class PropertyTable {
public:
  using Spec = std::function<GParamSpec *(GParamFlags)>;
  using Set = std::function<void (Settings &, const GValue *)>;
  using Get = std::function<void (const Settings &, GValue *)>;

  /* Any property: its spec and how it moves between a GValue and Settings. */
  PropertyTable &add (Spec spec, Set set, Get get)
  {
    entries_.push_back ({std::move (spec), std::move (set), std::move (get)});
    return *this;
  }

  PropertyTable &boolean (const char *name, const char *nick,
      const char *blurb, gboolean Settings::*field)
  {
    const gboolean def = Settings ().*field;
    return add ([=](GParamFlags f) {
          return g_param_spec_boolean (name, nick, blurb, def, f);
        },
        [=](Settings &s, const GValue *v) { s.*field = g_value_get_boolean (v); },
        [=](const Settings &s, GValue *v) { g_value_set_boolean (v, s.*field); });
  }

  /* A number: gint, guint, guint64 or gdouble, as the field is. */
  template <typename T>
  PropertyTable &number (const char *name, const char *nick,
      const char *blurb, T Settings::*field,
      typename std::common_type<T>::type min,
      typename std::common_type<T>::type max)
  {
    const T def = Settings ().*field;
    return add ([=](GParamFlags f) {
          return number_param_spec (name, nick, blurb, min, max, def, f);
        },
        [=](Settings &s, const GValue *v) { value_get_number (v, &(s.*field)); },
        [=](const Settings &s, GValue *v) { value_set_number (v, s.*field); });
  }

  /* A string; unset (NULL) and "" are both the empty string. */
  PropertyTable &string (const char *name, const char *nick,
      const char *blurb, std::string Settings::*field)
  {
    const std::string def = Settings ().*field;
    return add ([=](GParamFlags f) {
          return g_param_spec_string (name, nick, blurb,
              def.empty () ? nullptr : def.c_str (), f);
        },
        [=](Settings &s, const GValue *v) {
          const gchar *text = g_value_get_string (v);
          s.*field = text ? text : "";
        },
        [=](const Settings &s, GValue *v) {
          g_value_set_string (v, (s.*field).empty () ? nullptr :
              (s.*field).c_str ());
        });
  }

  /* A file name (palette, map): a string whose every set, even to the same
   * name, counts in generation, so that setting it re-reads the file. */
  PropertyTable &file (const char *name, const char *nick,
      const char *blurb, std::string Settings::*field,
      guint Settings::*generation)
  {
    string (name, nick, blurb, field);
    const Set set = entries_.back ().set;
    entries_.back ().set = [=](Settings &s, const GValue *v) {
      set (s, v);
      (s.*generation)++;
    };
    return *this;
  }

  /* A string whose empty value means "off" (e.g. a topic not sent): it
   * reads back as "", where an unset string reads back as NULL. */
  PropertyTable &string_or_empty (const char *name, const char *nick,
      const char *blurb, std::string Settings::*field)
  {
    string (name, nick, blurb, field);
    entries_.back ().get = [=](const Settings &s, GValue *v) {
      g_value_set_string (v, (s.*field).c_str ());
    };
    return *this;
  }

  template <typename Enum>
  PropertyTable &enumeration (const char *name, const char *nick,
      const char *blurb, Enum Settings::*field, GType type)
  {
    const Enum def = Settings ().*field;
    return add ([=](GParamFlags f) {
          return g_param_spec_enum (name, nick, blurb, type, (gint) def, f);
        },
        [=](Settings &s, const GValue *v) {
          s.*field = (Enum) g_value_get_enum (v);
        },
        [=](const Settings &s, GValue *v) {
          g_value_set_enum (v, (gint) (s.*field));
        });
  }

  /* The last property added may change only in this state or a lower
   * one (e.g. GST_PARAM_MUTABLE_READY where it sets the caps). */
  PropertyTable &mutable_in (guint mutability)
  {
    Spec spec = std::move (entries_.back ().spec);
    entries_.back ().spec = [spec, mutability](GParamFlags f) {
      return spec ((GParamFlags) ((f & ~(GST_PARAM_MUTABLE_PLAYING |
                      GST_PARAM_MUTABLE_PAUSED | GST_PARAM_MUTABLE_READY)) |
              mutability));
    };
    return *this;
  }

  /* The last property added can be set but not read (e.g. a password). */
  PropertyTable &write_only ()
  {
    Spec spec = std::move (entries_.back ().spec);
    entries_.back ().spec = [spec](GParamFlags f) {
      return spec ((GParamFlags) (f & ~G_PARAM_READABLE));
    };
    return *this;
  }

  /* The properties of a part of the Settings (e.g. the camera's, shared by
   * several elements), in the order of the part's table. */
  template <typename Part>
  PropertyTable &part (Part Settings::*member, const PropertyTable<Part> &t)
  {
    for (const auto &e : t.entries_)
      add (e.spec,
          [=](Settings &s, const GValue *v) { e.set (s.*member, v); },
          [=](const Settings &s, GValue *v) { e.get (s.*member, v); });
    return *this;
  }

  /* Installs the properties with ids first, first + 1, ... */
  void install (GObjectClass *klass, GParamFlags flags, guint first = 1) const
  {
    for (size_t i = 0; i < entries_.size (); i++)
      g_object_class_install_property (klass, first + (guint) i,
          entries_[i].spec (flags));
  }

  bool set (Settings &s, guint id, const GValue *v) const
  {
    if (id == 0 || id > entries_.size ())
      return false;
    entries_[id - 1].set (s, v);
    return true;
  }

  bool get (const Settings &s, guint id, GValue *v) const
  {
    if (id == 0 || id > entries_.size ())
      return false;
    entries_[id - 1].get (s, v);
    return true;
  }

private:
  template <typename> friend class PropertyTable;
  struct Entry {
    Spec spec;
    Set set;
    Get get;
  };
  std::vector<Entry> entries_;
};

/* The Settings as the application's threads set them, with a generation
 * that counts changes so the streaming thread re-parses only after one. */
template <typename Settings> class SharedSettings {
public:
  bool set (const PropertyTable<Settings> &t, guint id, const GValue *v)
  {
    std::lock_guard<std::mutex> lk (lock_);
    if (!t.set (settings_, id, v))
      return false;
    generation_++;
    return true;
  }

  bool get (const PropertyTable<Settings> &t, guint id, GValue *v) const
  {
    std::lock_guard<std::mutex> lk (lock_);
    return t.get (settings_, id, v);
  }

  /* A change made by the element itself (e.g. a value it learned). */
  template <typename Change> void update (Change change)
  {
    std::lock_guard<std::mutex> lk (lock_);
    change (settings_);
    generation_++;
  }

  guint generation () const
  {
    std::lock_guard<std::mutex> lk (lock_);
    return generation_;
  }

  Settings copy (guint *generation = nullptr) const
  {
    std::lock_guard<std::mutex> lk (lock_);
    if (generation)
      *generation = generation_;
    return settings_;
  }

  /* Copies the settings into out when they changed since *generation. */
  bool changed_since (guint *generation, Settings *out) const
  {
    std::lock_guard<std::mutex> lk (lock_);
    if (generation_ == *generation)
      return false;
    *out = settings_;
    *generation = generation_;
    return true;
  }

private:
  mutable std::mutex lock_;
  Settings settings_;
  guint generation_ = 0;
};

/* Defines get_type () of a GEnum registered as name, from its
 * {value, description, nick} entries. */
#define LANDMARK_DEFINE_ENUM_TYPE(get_type, name, ...)                       \
  GType get_type (void)                                                       \
  {                                                                           \
    static const GEnumValue values[] = { __VA_ARGS__, {0, nullptr, nullptr} };\
    static const GType type = g_enum_register_static (name, values);          \
    return type;                                                              \
  }

/* What an element of this pattern owns: the user's settings and what the
 * streaming thread keeps. */
template <typename Settings, typename State> struct ElementPrivate {
  SharedSettings<Settings> settings;
  State state;
};

/* The GObject skeleton of an element of this pattern, as G_DEFINE_TYPE is
 * GLib's. LANDMARK_DEFINE_ELEMENT_WITH_PRIVATE (TypeName, type_name,
 * SettingsType, ParentName, PARENT_TYPE, element, description) defines:
 * - struct _TypeName { ParentName parent; TypeName##Private *priv; };
 * - type_name##_get_type and type_name##_parent_class (G_DEFINE_TYPE),
 *   with the debug category type_name##_debug named `element` (declare it
 *   with GST_DEBUG_CATEGORY_STATIC first);
 * - the element's registration, GST_ELEMENT_REGISTER_DEFINE (element);
 * - static void type_name##_finalize (GObject *): deletes priv;
 * - static landmark::SharedSettings<SettingsType> &type_name##_settings
 *   (GObject *): the settings the property table reads and writes.
 * The element declares TypeName##Private itself (holding
 * `landmark::SharedSettings<SettingsType> settings`) and its _init. */
#define LANDMARK_DEFINE_ELEMENT_WITH_PRIVATE(TypeName, type_name, SettingsType,\
    ParentName, PARENT_TYPE, element, description)                            \
  struct _##TypeName                                                          \
  {                                                                           \
    ParentName parent;                                                        \
    TypeName##Private *priv;                                                  \
  };                                                                          \
  G_DEFINE_TYPE_WITH_CODE (TypeName, type_name, PARENT_TYPE,                  \
      GST_DEBUG_CATEGORY_INIT (type_name##_debug, #element, 0, description)); \
  GST_ELEMENT_REGISTER_DEFINE (element, #element, GST_RANK_NONE,              \
      type_name##_get_type ());                                               \
  static void type_name##_finalize (GObject * object)                         \
  {                                                                           \
    delete ((TypeName *) object)->priv;                                       \
    G_OBJECT_CLASS (type_name##_parent_class)->finalize (object);             \
  }                                                                           \
  static landmark::SharedSettings<SettingsType> &type_name##_settings (       \
      GObject * object)                                                       \
  {                                                                           \
    return ((TypeName *) object)->priv->settings;                             \
  }

/* The same for an element whose private part is
 * landmark::ElementPrivate<SettingsType, StateType> (TypeName##Private). */
#define LANDMARK_DEFINE_ELEMENT(TypeName, type_name, SettingsType, StateType, \
    ParentName, PARENT_TYPE, element, description)                            \
  using TypeName##Private = landmark::ElementPrivate<SettingsType, StateType>;\
  LANDMARK_DEFINE_ELEMENT_WITH_PRIVATE (TypeName, type_name, SettingsType,    \
      ParentName, PARENT_TYPE, element, description)

/* LANDMARK_DEFINE_ELEMENT and also static void type_name##_init
 * (TypeName *): priv created, the element set to work in place and never
 * drop a frame (init_metadata_element). */
#define LANDMARK_DEFINE_IN_PLACE_ELEMENT(TypeName, type_name, SettingsType,   \
    StateType, ParentName, PARENT_TYPE, element, description)                 \
  LANDMARK_DEFINE_ELEMENT (TypeName, type_name, SettingsType, StateType,      \
      ParentName, PARENT_TYPE, element, description);                         \
  static void type_name##_init (TypeName * self)                              \
  {                                                                           \
    self->priv = new TypeName##Private ();                                    \
    landmark::init_metadata_element (GST_BASE_TRANSFORM (self));              \
  }

/* Installs the table's properties and the set/get functions that read and
 * write them through shared (the element's SharedSettings). */
template <typename Settings, SharedSettings<Settings> &(*shared) (GObject *),
    const PropertyTable<Settings> &(*table) ()>
void
install_properties (GObjectClass *klass, GParamFlags flags)
{
  klass->set_property = [](GObject *object, guint id, const GValue *value,
      GParamSpec *pspec) {
    if (!shared (object).set (table (), id, value))
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, id, pspec);
  };
  klass->get_property = [](GObject *object, guint id, GValue *value,
      GParamSpec *pspec) {
    if (!shared (object).get (table (), id, value))
      G_OBJECT_WARN_INVALID_PROPERTY_ID (object, id, pspec);
  };
  table ().install (klass, flags);
}

/* Why settings were refused: the property and a sentence. */
struct SettingsError {
  const char *property = nullptr;
  std::string why;

  bool fail (const char *p, std::string w)
  {
    property = p;
    why = std::move (w);
    return false;
  }
};

/* Splits a comma-separated list of class names (spaces around them dropped);
 * an empty name fails, naming property. */
inline bool
parse_name_list (const std::string &text, const char *property,
    std::vector<std::string> *out, SettingsError *err)
{
  out->clear ();
  if (text.empty ())
    return true;
  gchar **parts = g_strsplit (text.c_str (), ",", -1);
  bool ok = true;
  for (gchar **p = parts; *p && ok; p++) {
    const gchar *name = g_strstrip (*p);
    if (*name)
      out->emplace_back (name);
    else
      ok = err->fail (property, "empty class name in \"" + text + "\"");
  }
  g_strfreev (parts);
  return ok;
}

/* The contents of a file a property names (a palette, a map), read at
 * start and again after each set of the property (its generation): the one
 * policy, with messages that name the file. At start a file that cannot be
 * used is an ERROR; while playing it is a WARNING and the previous contents
 * stay. load is bool (const std::string &path, Contents *, std::string
 * *why) and is called for the empty path too (no file: its own default). */
template <typename Contents> class SettingsFile {
public:
  Contents contents;
  std::string path;             /* the file of contents ("": none) */

  template <typename Load>
  bool start (GstElement *element, const char *what,
      const std::string &file, guint generation, Load load)
  {
    generation_ = generation;
    Contents c;
    std::string why;
    if (!load (file, &c, &why)) {
      GST_ELEMENT_ERROR (element, RESOURCE, SETTINGS,
          ("Could not use %s file \"%s\".", what, file.c_str ()),
          ("%s", why.c_str ()));
      return false;
    }
    contents = std::move (c);
    path = file;
    return true;
  }

  /* While playing: true when the contents were replaced. */
  template <typename Load>
  bool sync (GstElement *element, const char *what,
      const std::string &file, guint generation, Load load)
  {
    if (generation == generation_)
      return false;
    generation_ = generation;
    Contents c;
    std::string why;
    if (!load (file, &c, &why)) {
      GST_ELEMENT_WARNING (element, RESOURCE, SETTINGS,
          ("Could not use %s file \"%s\"; the previous %s stays.", what,
              file.c_str (), what), ("%s", why.c_str ()));
      return false;
    }
    contents = std::move (c);
    path = file;
    return true;
  }

private:
  guint generation_ = G_MAXUINT;
};

/* The parse of an element every value of whose properties is valid: its
 * Config is the Settings as set (member s). */
template <typename Settings, typename Config>
bool
accept_settings (const Settings &s, Config *cfg, SettingsError *)
{
  cfg->s = s;
  return true;
}

/* The streaming thread's view of the settings: the Config parsed from a
 * generation of them. parse is bool (const Settings &, Config *,
 * SettingsError *); without one every value is accepted as set. */
template <typename Settings, typename Config> class AppliedSettings {
public:
  Config config;

  /* At start: parses the current settings; a bad value posts an ERROR
   * naming the property and returns false. */
  template <typename Parse = decltype (&accept_settings<Settings, Config>)>
  bool start (GstElement *element, const SharedSettings<Settings> &shared,
      Parse parse = accept_settings<Settings, Config>)
  {
    const Settings s = shared.copy (&generation_);
    Config cfg;
    SettingsError err;
    if (!parse (s, &cfg, &err)) {
      GST_ELEMENT_ERROR (element, RESOURCE, SETTINGS,
          ("Invalid '%s' value.", err.property), ("%s", err.why.c_str ()));
      return false;
    }
    config = std::move (cfg);
    return true;
  }

  /* True when no property changed since the last start or sync. */
  bool current (const SharedSettings<Settings> &shared) const
  {
    return shared.generation () == generation_;
  }

  /* After a failed check: the next start parses again, whatever changed. */
  void invalidate () { generation_ = G_MAXUINT; }

  /* While playing: parses settings changed since the last call. A bad
   * value is warned about (once: it is not parsed again until the next
   * change) and the previous Config stays in force. True when config
   * changed. */
  template <typename Parse = decltype (&accept_settings<Settings, Config>)>
  bool sync (GstElement *element, const SharedSettings<Settings> &shared,
      Parse parse = accept_settings<Settings, Config>)
  {
    Settings s;
    if (!shared.changed_since (&generation_, &s))
      return false;
    Config cfg;
    SettingsError err;
    if (!parse (s, &cfg, &err)) {
      GST_ELEMENT_WARNING (element, RESOURCE, SETTINGS,
          ("Invalid '%s' value; keeping the previous settings.",
              err.property), ("%s", err.why.c_str ()));
      return false;
    }
    config = std::move (cfg);
    return true;
  }

private:
  guint generation_ = G_MAXUINT;
};

/* A file an element's settings name (labsegment's palette, the overlay's
 * map), whose other values are all valid as set: where State keeps it,
 * the Settings members of its path and of its sets, how it is read. */
template <typename State, typename Settings, typename Contents>
struct FileSetting {
  SettingsFile<Contents> State::*file;
  std::string Settings::*path;
  guint Settings::*generation;
  const char *what;
  bool (*load) (const std::string &, Contents *, std::string *);
};

/* The `apply` of such an element: its settings, then the file; read
 * (self) is told the file's contents are new. */
template <typename Self, typename State, typename Settings, typename Contents>
bool
apply_settings_and_file (Self *self,
    const FileSetting<State, Settings, Contents> &f, void (*read) (Self *))
{
  State &st = self->priv->state;
  if (!st.applied.start (GST_ELEMENT (self), self->priv->settings))
    return false;
  const Settings &s = st.applied.config.s;
  if (!(st.*f.file).start (GST_ELEMENT (self), f.what, s.*f.path,
          s.*f.generation, f.load))
    return false;
  read (self);
  return true;
}

/* While playing: settings changed since the last frame, and the file again
 * if a new one was set (a bad one: a warning, the previous stays). */
template <typename Self, typename State, typename Settings, typename Contents>
void
sync_settings_and_file (Self *self,
    const FileSetting<State, Settings, Contents> &f, void (*read) (Self *))
{
  State &st = self->priv->state;
  const Settings &s = st.applied.config.s;   /* the Config synced below */
  if (st.applied.sync (GST_ELEMENT (self), self->priv->settings)
      && (st.*f.file).sync (GST_ELEMENT (self), f.what, s.*f.path,
          s.*f.generation, f.load))
    read (self);
}

/* The one validation point of every element: one function `apply` (bool
 * (Self *), posting the ERROR) parses its settings and reads the files
 * they name when it goes from NULL to READY, so that a bad value fails
 * READY naming the property or file: the element's change_state is
 * change_state_checking_settings. When it starts (READY to PAUSED),
 * start_with_settings applies them again only if a property changed in
 * READY: the files read at READY are the ones the run uses. */
template <typename Self, GType (*get_type) (), bool (*apply) (Self *)>
GstStateChangeReturn
change_state_checking_settings (GstElement *element,
    GstStateChange transition)
{
  if (transition == GST_STATE_CHANGE_NULL_TO_READY
      && !apply (reinterpret_cast<Self *> (element)))
    return GST_STATE_CHANGE_FAILURE;
  auto parent = GST_ELEMENT_CLASS (g_type_class_peek_parent (
          g_type_class_peek (get_type ())));
  return parent->change_state (element, transition);
}

/* An element's AppliedSettings: in its State (`priv->state.applied`) or,
 * for an element with a private struct of its own, `priv->applied`. */
template <typename Private>
auto applied_settings_of (Private *priv) -> decltype ((priv->state.applied))
{
  return priv->state.applied;
}

template <typename Private>
auto applied_settings_of (Private *priv) -> decltype ((priv->applied))
{
  return priv->applied;
}

template <typename Self, bool (*apply) (Self *)>
bool
start_with_settings (Self *self)
{
  auto &applied = applied_settings_of (self->priv);
  if (applied.current (self->priv->settings))
    return true;
  if (apply (self))
    return true;
  /* a refused value stays refused when the start is tried again */
  applied.invalidate ();
  return false;
}

/* BaseTransform's start of an element of this pattern: its settings
 * applied again if a property changed in READY (start_with_settings), its
 * LabelsInput (if its State has one) started, then the element's own
 * start. */
template <typename Private>
auto
start_labels_input (Private *priv, int) -> decltype (priv->state.input.start ())
{
  priv->state.input.start ();
}

template <typename Private>
void
start_labels_input (Private *, long)
{
}

template <typename Self, bool (*apply) (Self *),
    gboolean (*start) (GstBaseTransform *)>
gboolean
start_checking_settings (GstBaseTransform *trans)
{
  Self *self = reinterpret_cast<Self *> (trans);
  if (!start_with_settings<Self, apply> (self))
    return FALSE;
  /* an element that reads labels starts from classes and caps unknown */
  start_labels_input (self->priv, 0);
  return start (trans);
}

/* The start of an element that has nothing of its own to start. */
inline gboolean
no_own_start (GstBaseTransform *)
{
  return TRUE;
}

/* Sets the element's change_state (change_state_checking_settings), its
 * start (start_checking_settings before the element's own, if it has
 * one) and its stop (null: the parent's). */
template <typename Self, GType (*get_type) (), bool (*apply) (Self *),
    gboolean (*start) (GstBaseTransform *) = no_own_start>
void
set_settings_lifecycle (gpointer klass,
    gboolean (*stop) (GstBaseTransform *) = nullptr)
{
  GST_ELEMENT_CLASS (klass)->change_state =
      change_state_checking_settings<Self, get_type, apply>;
  GST_BASE_TRANSFORM_CLASS (klass)->start =
      start_checking_settings<Self, apply, start>;
  if (stop)
    GST_BASE_TRANSFORM_CLASS (klass)->stop = stop;
}

/* The `apply` of an element whose settings are all it checks: its State's
 * AppliedSettings parsed by `parse`. */
template <typename Self, auto parse>
bool
apply_parsed (Self *self)
{
  return applied_settings_of (self->priv).start (GST_ELEMENT (self),
      self->priv->settings, parse);
}

/* The class set-up of an element that reads and writes metadata and
 * passes any video through unchanged: ANY video caps on both pads. */
inline void
set_metadata_element_class (GstElementClass *klass, const char *longname,
    const char *classification, const char *description)
{
  static GstStaticPadTemplate sink = GST_STATIC_PAD_TEMPLATE ("sink",
      GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS ("video/x-raw(ANY)"));
  static GstStaticPadTemplate src = GST_STATIC_PAD_TEMPLATE ("src",
      GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS ("video/x-raw(ANY)"));
  gst_element_class_set_static_metadata (klass, longname, classification,
      description, "gst-landmark developers");
  gst_element_class_add_static_pad_template (klass, &sink);
  gst_element_class_add_static_pad_template (klass, &src);
}

/* Every element's finalize and the properties of its table (changeable
 * while PLAYING unless the table says otherwise). */
template <typename Settings, SharedSettings<Settings> &(*shared) (GObject *),
    const PropertyTable<Settings> &(*table) ()>
void
install_element_properties (gpointer klass, void (*finalize) (GObject *))
{
  G_OBJECT_CLASS (klass)->finalize = finalize;
  install_properties<Settings, shared, table> (G_OBJECT_CLASS (klass),
      (GParamFlags) (G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
          GST_PARAM_MUTABLE_PLAYING));
}

/* The vfuncs of an element that measures labsegment's labels
 * (blobroundness, floorboundary, beacondetect): the settings lifecycle with
 * settings parsed by `parse`, its set_caps, and measure_labels_ip over sync
 * and process. */
template <typename Self, GType (*get_type) (), auto parse,
    gboolean (*start) (GstBaseTransform *), void (*sync) (Self *),
    GstFlowReturn (*process) (Self *, GstBuffer *, const GstStructure *)>
void
set_labels_measuring (gpointer klass, gboolean (*stop) (GstBaseTransform *),
    gboolean (*set_caps) (GstBaseTransform *, GstCaps *, GstCaps *))
{
  set_settings_lifecycle<Self, get_type, apply_parsed<Self, parse>,
      start> (klass, stop);
  GST_BASE_TRANSFORM_CLASS (klass)->set_caps = set_caps;
  GST_BASE_TRANSFORM_CLASS (klass)->transform_ip =
      measure_labels_ip<Self, sync, process>;
}

/* The class set-up of an element: finalize, the properties, its pads and
 * description. Without `configure` it passes video through unchanged (any
 * caps, in place); with it, it reads or draws pixels (labsegment,
 * landmarkoverlay: pads of LANDMARK_VIDEO_FORMATS and a set_info that hands
 * the negotiated format to configure). */
template <typename Settings, SharedSettings<Settings> &(*shared) (GObject *),
    const PropertyTable<Settings> &(*table) (),
    gboolean (*configure) (GstVideoFilter *, const LandmarkFrameFormat &,
        const GstVideoInfo *) = nullptr>
void
element_class_init (gpointer klass, void (*finalize) (GObject *),
    const char *longname, const char *classification,
    const char *description)
{
  install_element_properties<Settings, shared, table> (klass, finalize);
  GstElementClass *element_class = GST_ELEMENT_CLASS (klass);
  if constexpr (configure == nullptr) {
    set_metadata_element_class (element_class, longname, classification,
        description);
  } else {
    landmark_set_pixel_element_class (element_class, longname,
        classification, description);
    GST_VIDEO_FILTER_CLASS (klass)->set_info =
        landmark_pixel_set_info<configure>;
  }
}

/* Such an element works in place and never drops a late frame (frames
 * are never dropped by our elements). */
inline void
init_metadata_element (GstBaseTransform *trans)
{
  gst_base_transform_set_in_place (trans, TRUE);
  gst_base_transform_set_qos_enabled (trans, FALSE);
}

}  // namespace landmark
